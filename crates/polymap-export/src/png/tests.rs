use super::*;
use polymap::geometry::Segment;

fn seg(x0: f64, y0: f64, x1: f64, y1: f64) -> MapSegment {
    MapSegment {
        segment: Segment::new(Vec2::new(x0, y0), Vec2::new(x1, y1)),
        born_scan: 0,
    }
}

/// The colour at a map point, read back from the encoded PNG.
fn rgb_at(png: &[u8], (snapshot, style): &(MapSnapshot, PngStyle), p: Vec2) -> [u8; 3] {
    let pixmap = Pixmap::decode_png(png).expect("a PNG we wrote");
    let (view, _, _) = layout(&Scene::new(snapshot, style));
    let (x, y) = view.to_px(p);
    let px = pixmap
        .pixel(x as u32, y as u32)
        .expect("inside the picture");
    [px.red(), px.green(), px.blue()]
}

#[test]
fn segments_take_their_polyline_colour_and_the_size_follows_the_aspect() {
    let segments = [
        seg(0.0, 0.0, 20.0, 0.0),
        seg(0.0, 10.0, 20.0, 10.0),
        seg(0.0, 5.0, 5.0, 5.0),
    ];
    let polylines = [vec![0], vec![1, 7]];
    let trajectory = [Vec2::new(2.0, 2.0), Vec2::new(18.0, 2.0)];
    let scene = (
        MapSnapshot::from_parts(
            segments.to_vec(),
            polylines.to_vec(),
            &trajectory,
            Vec::new(),
        ),
        PngStyle {
            width_px: 800,
            ..Default::default()
        },
    );
    let png = render_png(&scene.0, &scene.1).expect("renders");
    let pixmap = Pixmap::decode_png(&png).expect("decodes");
    assert_eq!(pixmap.width(), 800);
    // 20 m x 10 m padded by 1.5 m each side: 23 x 13.
    assert_eq!(pixmap.height(), (800.0f64 * 13.0 / 23.0).round() as u32);
    assert_eq!(rgb_at(&png, &scene, Vec2::new(10.0, 0.0)), PALETTE_RGB[0]);
    assert_eq!(rgb_at(&png, &scene, Vec2::new(10.0, 10.0)), PALETTE_RGB[1]);
    assert_eq!(rgb_at(&png, &scene, Vec2::new(2.5, 5.0)), LOOSE_RGB);
    assert_eq!(rgb_at(&png, &scene, Vec2::new(10.0, 2.0)), TRAJECTORY_RGB);
    assert_eq!(rgb_at(&png, &scene, Vec2::new(10.0, 7.0)), [255, 255, 255]);
}

#[test]
fn tall_maps_are_capped_and_empty_scenes_render() {
    let segments = [seg(0.0, 0.0, 0.0, 10_000.0)];
    let scene = MapSnapshot::from_parts(segments.to_vec(), Vec::new(), &[], Vec::new());
    let png = render_png(&scene, &PngStyle::default()).expect("renders");
    let pixmap = Pixmap::decode_png(&png).expect("decodes");
    assert_eq!(pixmap.height(), MAX_SIDE_PX);
    assert!(
        pixmap.width() < 1000,
        "width shrinks with the scale: {}",
        pixmap.width()
    );
    let empty = render_png(&MapSnapshot::default(), &PngStyle::default()).expect("renders");
    let pixmap = Pixmap::decode_png(&empty).expect("decodes");
    assert_eq!(
        (pixmap.width(), pixmap.height()),
        (DEFAULT_WIDTH_PX, DEFAULT_WIDTH_PX)
    );
}

#[test]
fn scan_points_are_grey_and_decimated() {
    let points: Vec<Vec2> = (0..1000)
        .map(|i| Vec2::new(f64::from(i) * 0.01, 1.0))
        .collect();
    let scene = (
        MapSnapshot::from_parts(Vec::new(), Vec::new(), &[], points),
        PngStyle {
            max_scan_points: 10,
            width_px: 400,
        },
    );
    let png = render_png(&scene.0, &scene.1).expect("renders");
    assert_eq!(
        rgb_at(&png, &scene, Vec2::new(0.0, 1.0)),
        [0x9a, 0xa0, 0xa6]
    );
    assert_eq!(rgb_at(&png, &scene, Vec2::new(0.5, 1.0)), [255, 255, 255]);
}

#[test]
fn write_png_names_the_file_on_error() {
    let path = Path::new("/nonexistent-dir/map.png");
    let err = write_png(path, &MapSnapshot::default(), &PngStyle::default())
        .expect_err("no such directory");
    assert!(
        err.to_string().contains("/nonexistent-dir/map.png"),
        "{err}"
    );
}

/// A map too large to draw (its extent not finite) is an error naming the file, not one with an
/// empty file name and a "0 x 0 picture".
#[test]
fn a_map_too_large_to_draw_is_a_clear_error_naming_the_file() {
    use polymap::geometry::Segment;
    use polymap::map::MapSegment;
    let huge = [MapSegment {
        segment: Segment::new(Vec2::new(-1.7e308, 0.0), Vec2::new(1.7e308, 1.0)),
        born_scan: 0,
    }];
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.png");
    let err = write_png(
        &path,
        &MapSnapshot::from_parts(huge.to_vec(), Vec::new(), &[], Vec::new()),
        &PngStyle::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("big.png") && err.contains("not finite"),
        "{err}"
    );
}
