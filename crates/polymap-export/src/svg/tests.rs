use polymap::map::MapSegment;

use super::*;

/// A snapshot of the given parts.
fn snap(
    title: &str,
    segments: &[MapSegment],
    polylines: &[Vec<usize>],
    trajectory: &[Vec2],
    points: &[Vec2],
) -> MapSnapshot {
    MapSnapshot {
        title: title.to_owned(),
        ..MapSnapshot::from_parts(
            segments.to_vec(),
            polylines.to_vec(),
            trajectory,
            points.to_vec(),
        )
    }
}

fn segment(x0: f64, y0: f64, x1: f64, y1: f64) -> MapSegment {
    MapSegment {
        segment: Segment::new(Vec2::new(x0, y0), Vec2::new(x1, y1)),
        born_scan: 0,
    }
}

fn parse(svg: &str) -> roxmltree::Document<'_> {
    match roxmltree::Document::parse(svg) {
        Ok(doc) => doc,
        Err(e) => panic!("not well-formed XML: {e}\n{svg}"),
    }
}

fn paths_with_title<'a>(
    doc: &'a roxmltree::Document<'a>,
    prefix: &str,
) -> Vec<roxmltree::Node<'a, 'a>> {
    doc.descendants()
        .filter(|n| n.has_tag_name("path"))
        .filter(|n| {
            n.children()
                .any(|c| c.has_tag_name("title") && c.text().is_some_and(|t| t.starts_with(prefix)))
        })
        .collect()
}

#[test]
fn full_scene_is_well_formed_with_flipped_metre_view_box() {
    let segments = [
        segment(0.0, 0.0, 20.0, 0.0),
        segment(20.0, 0.0, 20.0, 10.0),
        segment(0.0, 10.0, 5.0, 10.0),
    ];
    let polylines = [vec![0, 1], vec![7]];
    let trajectory = [
        Vec2::new(1.0, 1.0),
        Vec2::new(2.0, 1.5),
        Vec2::new(3.0, 2.0),
    ];
    let points: Vec<Vec2> = (0..1000)
        .map(|i| Vec2::new(i as f64 * 0.02, 0.05))
        .collect();
    let scene = snap(
        "intel & \"friends\" <run 1> 'x'",
        &segments,
        &polylines,
        &trajectory,
        &points,
    );
    let svg = render_svg(&scene, &SvgStyle::default());
    let doc = parse(&svg);
    let root = doc.root_element();
    assert_eq!(root.tag_name().name(), "svg");
    let view_box: Vec<f64> = root
        .attribute("viewBox")
        .unwrap()
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    // x from below 0 to above 20; y flipped: the top edge is -(max y) < -10.
    assert!(view_box[0] < 0.0 && view_box[0] + view_box[2] > 20.0);
    assert!(view_box[1] < -10.0 && view_box[1] + view_box[3] > 0.0);
    let title = doc.descendants().find(|n| n.has_tag_name("title")).unwrap();
    assert_eq!(title.text(), Some("intel & \"friends\" <run 1> 'x'"));
    assert!(
        doc.descendants()
            .any(|n| n.has_tag_name("g") && n.attribute("transform") == Some("scale(1 -1)"))
    );
    assert_eq!(
        paths_with_title(&doc, "polyline").len(),
        1,
        "polyline 1 has no valid segment"
    );
    assert_eq!(paths_with_title(&doc, "segments in no polyline").len(), 1);
    assert!(doc.descendants().any(|n| n.has_tag_name("circle")));
    // librsvg ignores vector-effect: widths must be right without it, in metres, about
    // 2 px at the nominal width (the view is about 23 m wide, 1200 px).
    for path in doc.descendants().filter(|n| n.has_tag_name("path")) {
        assert_eq!(path.attribute("vector-effect"), None);
        let w: f64 = path.attribute("stroke-width").unwrap().parse().unwrap();
        assert!(w > 0.005 && w < 0.05, "stroke width {w} m");
    }
}

#[test]
fn each_polyline_has_its_own_colour() {
    let segments: Vec<MapSegment> = (0..5)
        .map(|i| segment(i as f64, 0.0, i as f64, 1.0))
        .collect();
    let polylines: Vec<Vec<usize>> = (0..5).map(|i| vec![i]).collect();
    let scene = snap("", &segments, &polylines, &[], &[]);
    let svg = render_svg(&scene, &SvgStyle::default());
    let doc = parse(&svg);
    let colours: Vec<&str> = paths_with_title(&doc, "polyline")
        .iter()
        .map(|n| n.attribute("stroke").unwrap())
        .collect();
    assert_eq!(
        colours,
        PALETTE_RGB[..5]
            .iter()
            .map(|c| crate::picture::hex(*c))
            .collect::<Vec<_>>()
    );
}

#[test]
fn scale_bar_has_a_round_label() {
    let segments = [segment(0.0, 0.0, 37.0, 12.0)];
    let svg = render_svg(&snap("", &segments, &[], &[], &[]), &SvgStyle::default());
    let doc = parse(&svg);
    let bar = doc
        .descendants()
        .find(|n| n.attribute("class") == Some("scale-bar"))
        .unwrap();
    let label = bar
        .descendants()
        .find(|n| n.has_tag_name("text"))
        .unwrap()
        .text()
        .unwrap();
    // View ≈ 37 + 2·(0.05·37 + 0.5) ≈ 41.7 m wide; 20% of it is 8.3 m → a 5 m bar.
    assert_eq!(label, "5 m");
}

#[test]
fn scan_points_are_decimated_to_the_cap() {
    let points: Vec<Vec2> = (0..10_001)
        .map(|i| Vec2::new(i as f64 * 1e-3, 0.0))
        .collect();
    let scene = snap("", &[], &[], &[], &points);
    let svg = render_svg(
        &scene,
        &SvgStyle {
            max_scan_points: 1000,
        },
    );
    parse(&svg);
    let drawn = svg.matches("h0").count();
    assert!((900..=1000).contains(&drawn), "{drawn}");
}

#[test]
fn empty_and_degenerate_scenes_are_well_formed() {
    parse(&render_svg(&MapSnapshot::default(), &SvgStyle::default()));
    let segments = [
        segment(f64::NAN, 0.0, 1.0, f64::INFINITY),
        segment(3.0, 3.0, 3.0, 3.0),
    ];
    let trajectory = [Vec2::new(f64::NAN, 1.0)];
    let scene = snap("\u{1}control\u{0} chars", &segments, &[], &trajectory, &[]);
    let svg = render_svg(&scene, &SvgStyle::default());
    parse(&svg);
    assert!(!svg.contains("NaN") && !svg.contains("inf"));
}

#[test]
fn numbers_are_compact() {
    assert_eq!(num(1.5), "1.5");
    assert_eq!(num(2.0), "2");
    assert_eq!(num(-0.0001), "0");
    assert_eq!(num(-12.34567), "-12.346");
}
