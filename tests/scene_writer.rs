//! The scene writer round-trips: what it writes parses to the same
//! description and builds the same model, for every bundled scene and for
//! random trees of every node kind.

use blobtrace::scene::{Scene, SceneDesc, parse_desc};
use proptest::prelude::*;

/// Writes `desc`, reads it back, and checks both descriptions and both
/// models agree and that writing again gives the same text.
fn round_trip(desc: &SceneDesc, label: &str) {
    let written = desc.to_ron(&[format!("{label}, written back")]).expect("a scene writes");
    let read = parse_desc(&written, label).unwrap_or_else(|e| panic!("{e}\n{written}"));
    assert_eq!(&read, desc, "{label}: the description changed\n{written}");
    assert_eq!(read.to_ron(&[format!("{label}, written back")]).unwrap(), written, "{label}: writing is not stable");
    match (Scene::from_desc(desc), Scene::from_desc(&read)) {
        (Ok(a), Ok(b)) => {
            assert_eq!(
                format!("{:?}", a.model.nodes()),
                format!("{:?}", b.model.nodes()),
                "{label}: the model changed"
            );
            assert_eq!((a.look_at, a.size, a.background), (b.look_at, b.size, b.background));
        }
        (Err(a), Err(b)) => assert_eq!(a, b),
        (a, b) => panic!("{label}: one builds, the other not: {:?} / {:?}", a.err(), b.err()),
    }
}

#[test]
fn every_bundled_scene_round_trips() {
    let mut seen = 0;
    for entry in std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "ron") {
            let text = std::fs::read_to_string(&path).unwrap();
            round_trip(&parse_desc(&text, &path.display().to_string()).unwrap(), &path.display().to_string());
            seen += 1;
        }
    }
    assert!(seen >= 9, "the bundled scenes were found");
}

/// Any finite number, written with every bit it has.
fn number() -> impl Strategy<Value = String> {
    (-50.0f32..50.0).prop_map(|v| format!("{v:?}"))
}

fn positive() -> impl Strategy<Value = String> {
    (1e-3f32..5.0).prop_map(|v| format!("{v:?}"))
}

fn triple() -> impl Strategy<Value = String> {
    (number(), number(), number()).prop_map(|(x, y, z)| format!("({x}, {y}, {z})"))
}

fn optional(field: &'static str, value: impl Strategy<Value = String>) -> impl Strategy<Value = String> {
    prop::option::of(value).prop_map(move |v| v.map_or(String::new(), |v| format!(", {field}: {v}")))
}

fn color() -> impl Strategy<Value = String> {
    (0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0).prop_map(|(r, g, b)| format!("({r:?}, {g:?}, {b:?})"))
}

fn leaf() -> impl Strategy<Value = String> {
    let kernel = Just("Wyvill");
    prop_oneof![
        (
            triple(),
            positive(),
            optional("weight", number()),
            optional("kernel", kernel.prop_map(String::from)),
            optional("color", color())
        )
            .prop_map(|(c, r, w, k, col)| format!("Point(center: {c}, radius: {r}{w}{k}{col})")),
        (triple(), triple(), positive(), optional("color", color()))
            .prop_map(|(a, b, r, col)| format!("Segment(a: {a}, b: {b}, radius: {r}{col})")),
        (triple(), positive(), positive(), optional("normal", Just("(0.3, 1.0, 0.2)".to_string())))
            .prop_map(|(c, ring, r, n)| format!("Circle(center: {c}, ring: {ring}, radius: {r}{n})")),
        (prop::collection::vec(triple(), 1..4), 1u32..40, positive(), optional("radius_end", positive())).prop_map(
            |(cs, n, r, e)| format!("SplinePoints(control: [{}], count: {n}, radius: {r}{e})", cs.join(", "))
        ),
    ]
}

fn tree() -> impl Strategy<Value = String> {
    leaf().prop_recursive(4, 24, 4, |inner| {
        let list = prop::collection::vec(inner.clone(), 1..4).prop_map(|v| v.join(", "));
        let filter = prop::sample::select(vec!["Trilinear", "Triquadratic"]);
        prop_oneof![
            list.clone().prop_map(|l| format!("Blend([{l}])")),
            list.clone().prop_map(|l| format!("Union([{l}])")),
            list.clone().prop_map(|l| format!("Intersection([{l}])")),
            (1.0f32..6.0, list).prop_map(|(n, l)| format!("Ricci(n: {n:?}, children: [{l}])")),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("Difference({a}, {b})")),
            (
                optional("translate", triple()),
                optional("rotate", triple()),
                optional("scale", Just("(1.5, -0.5, 2.0)".into())),
                inner.clone()
            )
                .prop_map(|(t, r, s, c)| format!("Transform(child: {c}{t}{r}{s})")),
            (number(), inner.clone()).prop_map(|(k, c)| format!("Twist(axis: X, rate: {k}, child: {c})")),
            (inner.clone(), positive())
                .prop_map(|(c, s)| format!("Taper(from: -1.0, to: 2.0, scale_to: {s}, child: {c})")),
            ((-0.05f32..0.05), inner.clone()).prop_map(|(k, c)| format!("Bend(rate: {k:?}, child: {c})")),
            (
                2u32..300,
                filter,
                optional("storage", Just("F16".to_string())),
                optional("use", Just("Never".to_string())),
                inner.clone()
            )
                .prop_map(|(r, f, s, u, c)| format!("Cache(res: {r}, value: {f}{s}{u}, child: {c})")),
            ("[a-z]{1,8}", inner).prop_map(|(n, c)| format!("Named(\"{n}\", {c})")),
        ]
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn random_trees_round_trip(model in tree(), background in optional("background", color()), threshold in positive()) {
        let text = format!(
            "Scene(camera: Camera(eye: (0.0, 1.0, 9.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (32, 24), threshold: {threshold}{background}, model: {model})"
        );
        // Random names may repeat, and random warps may leave their domain:
        // such scenes still parse, and must fail to build the same way twice.
        let desc = parse_desc(&text, "random").map_err(|e| TestCaseError::fail(format!("{e}\n{text}")))?;
        round_trip(&desc, "random");
    }
}
