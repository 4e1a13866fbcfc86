//! The scene writer: a [`SceneDesc`] back to RON text that [`super::parse_desc`]
//! reads as the same description, so a tool that changes a scene (`tune`) can
//! hand it back as a file.
//!
//! Numbers are written in their shortest form that reads back to the same
//! bits; fields at their defaults are left out; a generator (`SplinePoints`)
//! stays a generator.

use ron::ser::PrettyConfig;

use super::desc::SceneDesc;

impl SceneDesc {
    /// This scene as RON text, `header` (comment lines, each without its
    /// `//`) first.
    pub fn to_ron(&self, header: &[String]) -> Result<String, ron::Error> {
        let config = PrettyConfig::new().struct_names(true).indentor("    ").new_line("\n");
        // The reader's options, so whatever it reads (MAX_DEPTH levels of
        // nodes) is written back, on a stack as deep as the reader's.
        let body = super::on_a_deep_stack(|| super::ron_options().to_string_pretty(self, config))?;
        let mut out: String = header.iter().map(|line| format!("// {line}\n")).collect();
        out.push_str(&body);
        out.push('\n');
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::super::parse_desc;

    #[test]
    fn a_written_scene_reads_back_the_same_with_defaults_left_out() {
        let text = r#"Scene(camera: Camera(eye: (0.0, 1.0, 6.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (64, 48),
            model: Blend([Point(center: (0.1, 1e-7, -3.25), radius: 1.0, color: (0.2, 0.4, 0.6)),
                Named("arm", Transform(rotate: (0.0, 0.0, 30.0), child: Segment(a: (0.0, 0.0, 0.0), b: (1.5, 0.0, 0.0), radius: 0.5))),
                Cache(res: 64, use: Always, child: Twist(rate: 0.3, child: Circle(center: (0.0, 0.0, 0.0), ring: 1.0, radius: 0.3)))]))"#;
        let desc = parse_desc(text, "t").unwrap();
        let written = desc.to_ron(&["a header".into()]).unwrap();
        assert!(written.starts_with("// a header\nScene("), "{written}");
        assert_eq!(parse_desc(&written, "w").unwrap(), desc, "{written}");
        // Defaults stay out; what differs from them is written.
        for absent in ["weight", "kernel", "Some(", "translate", "storage", "normal"] {
            assert!(!written.contains(absent), "{absent} in {written}");
        }
        for present in ["use: Always", "rotate: (0.0, 0.0, 30.0)", "1e-7", "color: (0.2, 0.4, 0.6)"] {
            assert!(written.contains(present), "{present} not in {written}");
        }
    }
}
