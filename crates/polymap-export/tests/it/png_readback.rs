//! The PNG export decoded with the `png` crate.

use polymap::geometry::Vec2;
use polymap_export::png::{PngStyle, write_png};
use polymap_io::snapshot::MapSnapshot;

use crate::room;

#[test]
fn png_decodes_with_the_expected_size_and_coloured_walls() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("map.png");
    let (segments, polylines) = room::map_segments();
    let trajectory: Vec<Vec2> = (0..50).map(|t| room::pose(t, 50).translation()).collect();
    let scene = MapSnapshot::from_parts(segments, polylines, &trajectory, Vec::new());
    let style = PngStyle {
        width_px: 1000,
        ..Default::default()
    };
    write_png(&path, &scene, &style).expect("written");

    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(&path).expect("open"),
    ));
    let mut reader = decoder.read_info().expect("PNG header");
    let mut buf = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buf).expect("PNG data");
    // 10 m x 8 m padded by 1 m each side: 12 x 10.
    assert_eq!((info.width, info.height), (1000, 833));
    assert_eq!(info.color_type, png::ColorType::Rgba);
    let px_per_m = 1000.0 / 12.0;
    let rgba = |p: Vec2| {
        let x = ((p.x + 1.0) * px_per_m) as usize;
        let y = ((9.0 - p.y) * px_per_m) as usize;
        let i = 4 * (y * info.width as usize + x);
        [buf[i], buf[i + 1], buf[i + 2], buf[i + 3]]
    };
    // The bottom wall is the first polyline (Tableau blue), the room's middle is white.
    assert_eq!(rgba(Vec2::new(5.5, 0.0)), [0x4e, 0x79, 0xa7, 255]);
    assert_eq!(rgba(Vec2::new(10.0, 4.5)), [0xf2, 0x8e, 0x2b, 255]);
    assert_eq!(rgba(Vec2::new(5.0, 5.0)), [255, 255, 255, 255]);
}
