//! What an edit replay writes into its folder: frames.csv (a row per frame),
//! the timing plot, and, when asked, every frame's field image with its dirty
//! rectangles outlined — all of them or none, once the whole script has
//! played, so a script that fails part way writes nothing.

use std::fmt::Write as _;
use std::path::Path;

use super::edit_session::outline_dirty;
use super::error::{PipelineError, Result};
use super::replay::EditReport;
use crate::draw::{frame_image, line_plot};
use crate::frame::Frame;
use crate::output::FileSet;
use crate::trace::PixelRect;

/// Frames kept as a replay plays, to be written with its report.
#[derive(Debug, Default)]
pub struct KeptFrames {
    /// Each frame's number and PNG bytes.
    pngs: Vec<(usize, Vec<u8>)>,
}

impl KeptFrames {
    /// Keeps frame `i`'s field image with `rects` outlined.
    pub fn keep(&mut self, i: usize, frame: &Frame, rects: &[PixelRect]) -> Result<()> {
        let mut img = frame_image(frame);
        outline_dirty(&mut img, rects);
        self.pngs.push((i, img.png_bytes_for(Path::new(&frame_name(i)))?));
        Ok(())
    }
}

/// The file name of frame `i`.
fn frame_name(i: usize) -> String {
    format!("frame-{i:04}.png")
}

impl EditReport {
    /// Writes frames.csv, timing.png and the `frames` kept into `dir`
    /// (created if missing), all of them or none.
    pub fn save(&self, dir: &Path, frames: KeptFrames) -> Result<()> {
        let mut files = FileSet::new();
        for (i, png) in frames.pngs {
            files.add(dir.join(frame_name(i)), png);
        }
        let timing = dir.join("timing.png");
        files.add(dir.join("frames.csv"), self.frames_csv().into_bytes());
        files.add(&timing, self.timing_plot().png_bytes_for(&timing)?);
        std::fs::create_dir_all(dir).map_err(|e| PipelineError::File {
            path: dir.to_path_buf(),
            message: format!("could not create the folder: {e}"),
        })?;
        Ok(files.commit()?)
    }

    /// Seconds per frame: incremental, its field and mesh parts, and from scratch when verified.
    fn timing_plot(&self) -> crate::draw::Rgb8Image {
        let rows = &self.per_frame;
        let incremental: Vec<f64> = rows.iter().map(|f| f.incremental_s).collect();
        let field: Vec<f64> = rows.iter().map(|f| f.field_s).collect();
        let mesh: Vec<f64> = rows.iter().map(|f| f.polygonize_s + f.bvh_s + f.mesh_render_s).collect();
        let full: Vec<f64> = rows.iter().map(|f| f.full_s.unwrap_or(f64::NAN)).collect();
        let mut series: Vec<(&str, &[f64])> = vec![("incremental", &incremental), ("field", &field), ("mesh", &mesh)];
        if self.full_s.is_some() {
            series.push(("from scratch", &full));
        }
        line_plot(&format!("seconds per frame ({})", self.eval), "s", &series, 720, 360)
    }

    /// frames.csv: a header and a row per frame.
    fn frames_csv(&self) -> String {
        let mut csv = String::from(
            "frame,dirty_fraction,retraced_fraction,field_evals,apply_s,field_s,polygonize_s,bvh_s,bvh_rebuilt,mesh_render_s,diff_s,incremental_s,full_s,samples_cleared,triangles\n",
        );
        for f in &self.per_frame {
            let full = f.full_s.map_or(String::new(), |v| format!("{v:.6}"));
            let _ = writeln!(
                csv,
                "{},{:.5},{:.5},{},{:.6},{:.6},{:.6},{:.6},{},{:.6},{:.6},{:.6},{full},{},{}",
                f.frame,
                f.dirty_fraction,
                f.retraced_fraction,
                f.field_evals,
                f.apply_s,
                f.field_s,
                f.polygonize_s,
                f.bvh_s,
                f.bvh_rebuilt,
                f.mesh_render_s,
                f.diff_s,
                f.incremental_s,
                f.samples_cleared,
                f.triangles
            );
        }
        csv
    }
}
