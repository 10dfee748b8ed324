//! The map_server export parsed back: the PGM header and bytes, and the YAML with a YAML parser.

use polymap::geometry::Vec2;
use polymap_export::pgm::{GridParams, OccupancyGrid, write_map_server};
use serde::Deserialize;

use crate::room;

/// The fields `map_server` reads.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MapYaml {
    image: String,
    resolution: f64,
    origin: [f64; 3],
    negate: i32,
    occupied_thresh: f64,
    free_thresh: f64,
    mode: String,
}

/// A minimal binary PGM reader: `(width, height, maxval, pixels)`.
fn read_p5(bytes: &[u8]) -> (usize, usize, u32, &[u8]) {
    let mut fields = Vec::new();
    let mut i = 2;
    assert_eq!(&bytes[..2], b"P5");
    while fields.len() < 3 {
        while bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        let start = i;
        while !bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        let text = std::str::from_utf8(&bytes[start..i]).expect("ASCII header");
        fields.push(text.parse::<usize>().expect("a number"));
    }
    // Exactly one whitespace byte separates the header from the raster.
    let pixels = &bytes[i + 1..];
    (fields[0], fields[1], fields[2] as u32, pixels)
}

#[test]
fn map_server_files_read_back_with_values_origin_and_cells() {
    let dir = tempfile::tempdir().expect("temp dir");
    let n = 60;
    let rays = (0..n).map(|t| {
        let p = room::pose(t, n);
        (p, room::scan(&p))
    });
    let params = GridParams::default();
    let grid = OccupancyGrid::build(&room::walls(), rays, &params).expect("grid");
    let files = write_map_server(dir.path(), "map", &grid).expect("written");

    let yaml: MapYaml =
        serde_yaml_ng::from_str(&std::fs::read_to_string(&files.yaml).expect("yaml"))
            .expect("parses");
    assert_eq!(yaml.image, "map.pgm");
    assert_eq!(yaml.resolution, 0.05);
    assert_eq!(yaml.mode, "trinary");
    assert_eq!(
        (yaml.negate, yaml.occupied_thresh, yaml.free_thresh),
        (0, 0.65, 0.196)
    );
    // The room spans [0, 10] x [0, 8]; with the 1 m margin the lower-left corner is (-1, -1).
    assert!((yaml.origin[0] + 1.0).abs() < 1e-9 && (yaml.origin[1] + 1.0).abs() < 1e-9);
    assert_eq!(yaml.origin[2], 0.0);

    let bytes = std::fs::read(&files.pgm).expect("pgm");
    let (w, h, maxval, pixels) = read_p5(&bytes);
    assert_eq!((w, h, maxval), (240, 200, 255));
    assert_eq!(pixels.len(), w * h);
    // The pixel of a map point, as map_server maps it: column from x, row from the top.
    let pixel = |p: Vec2| {
        let col = ((p.x - yaml.origin[0]) / yaml.resolution).floor() as usize;
        let row_from_bottom = ((p.y - yaml.origin[1]) / yaml.resolution).floor() as usize;
        pixels[(h - 1 - row_from_bottom) * w + col]
    };
    let occupancy = |v: u8| (255.0 - f64::from(v)) / 255.0;
    // On a wall: occupied. Near the robot's path: free. Outside the room: unknown.
    assert!(occupancy(pixel(Vec2::new(5.02, 0.01))) > yaml.occupied_thresh);
    assert!(occupancy(pixel(Vec2::new(10.01, 3.03))) > yaml.occupied_thresh);
    assert!(occupancy(pixel(Vec2::new(5.03, 4.02))) < yaml.free_thresh);
    assert!(occupancy(pixel(Vec2::new(8.04, 4.01))) < yaml.free_thresh);
    let outside = occupancy(pixel(Vec2::new(-0.5, -0.5)));
    assert!(outside > yaml.free_thresh && outside < yaml.occupied_thresh);
}

#[test]
fn write_map_server_names_the_file_it_could_not_write() {
    let grid = OccupancyGrid::build(
        &room::walls(),
        std::iter::empty::<(polymap::geometry::Pose2, Vec<Vec2>)>(),
        &GridParams::default(),
    )
    .expect("grid");
    let err = write_map_server(std::path::Path::new("/nonexistent-dir"), "map", &grid)
        .expect_err("no such directory");
    assert!(
        err.to_string().contains("/nonexistent-dir/map.pgm"),
        "{err}"
    );
}
