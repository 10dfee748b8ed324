//! map.svg through librsvg (`rsvg-convert`), the renderer of GNOME's viewers, which can draw
//! `vector-effect="non-scaling-stroke"` lines of width "2" as 2 m wide strokes and a scale bar
//! as a black box: the picture must come out with thin walls and a thin scale bar.

use std::process::Command;

use polymap::geometry::Vec2;
use polymap_export::picture::PALETTE_RGB;
use polymap_export::svg::{SvgStyle, write_svg};
use polymap_io::snapshot::MapSnapshot;

use crate::{room, tools};

#[test]
fn map_svg_renders_thin_lines_in_librsvg() {
    let Some(rsvg) = tools::required(&["rsvg-convert"], ".ci/run installs librsvg2-bin") else {
        return;
    };
    let (segments, polylines) = room::map_segments();
    let trajectory: Vec<Vec2> = (0..50).map(|t| room::pose(t, 50).translation()).collect();
    let snapshot = MapSnapshot {
        title: "room".into(),
        ..MapSnapshot::from_parts(segments, polylines, &trajectory, Vec::new())
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let svg = dir.path().join("map.svg");
    let png = dir.path().join("map.png");
    write_svg(&svg, &snapshot, &SvgStyle::default()).expect("written");
    let out = Command::new(rsvg)
        .args(["-w", "1200", "-b", "white", "-o"])
        .arg(&png)
        .arg(&svg)
        .output()
        .expect("rsvg-convert runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).unwrap()));
    let mut reader = decoder.read_info().expect("PNG header");
    let mut buf = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buf).expect("PNG data");
    let channels = info.color_type.samples();
    let pixels: Vec<&[u8]> = buf[..info.buffer_size()].chunks(channels).collect();
    let share = |pred: &dyn Fn(&[u8]) -> bool| {
        pixels.iter().filter(|p| pred(p)).count() as f64 / pixels.len() as f64
    };
    let dark = share(&|p| p[0] < 80 && p[1] < 80 && p[2] < 80);
    let near = |c: [u8; 3]| move |p: &[u8]| (0..3).all(|i| p[i].abs_diff(c[i]) < 60);
    let walls = share(&near(PALETTE_RGB[0]));
    let white = share(&|p| p[0] > 240 && p[1] > 240 && p[2] > 240);
    println!("rsvg: dark {dark:.4}, wall colour {walls:.4}, white {white:.4}");
    // Text and a thin scale bar, not a black box; walls drawn, but as lines.
    assert!(dark < 0.02, "dark share {dark}");
    assert!(walls > 0.0005 && walls < 0.05, "wall share {walls}");
    assert!(white > 0.8, "white share {white}");
}
