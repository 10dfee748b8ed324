//! The DXF export read back with the `dxf` crate.

use ::dxf::Drawing;
use ::dxf::entities::EntityType;
use ::dxf::enums::AcadVersion;
use polymap::geometry::Vec2;
use polymap_export::dxf::{MAP_LAYER, TRAJECTORY_LAYER, write_dxf};
use polymap_io::snapshot::MapSnapshot;

use crate::room;

#[test]
fn dxf_reads_back_with_lines_layers_and_the_trajectory() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("map.dxf");
    let (segments, polylines) = room::map_segments();
    let trajectory: Vec<Vec2> = (0..50).map(|t| room::pose(t, 50).translation()).collect();
    let scene = MapSnapshot::from_parts(segments.clone(), polylines, &trajectory, Vec::new());
    write_dxf(&path, &scene).expect("written");

    let drawing = Drawing::load_file(&path).expect("the dxf crate reads it");
    assert_eq!(drawing.header.version, AcadVersion::R12);
    let layers: Vec<&str> = drawing.layers().map(|l| l.name.as_str()).collect();
    assert!(
        layers.contains(&MAP_LAYER) && layers.contains(&TRAJECTORY_LAYER),
        "{layers:?}"
    );

    let mut lines = Vec::new();
    let mut polyline_vertices = Vec::new();
    for e in drawing.entities() {
        match &e.specific {
            EntityType::Line(l) => {
                assert_eq!(e.common.layer, MAP_LAYER);
                lines.push((l.p1.clone(), l.p2.clone(), e.common.color.index()));
            }
            EntityType::Polyline(p) => {
                assert_eq!(e.common.layer, TRAJECTORY_LAYER);
                polyline_vertices.extend(p.vertices().map(|v| v.location.clone()));
            }
            other => panic!("unexpected entity {other:?}"),
        }
    }
    assert_eq!(lines.len(), segments.len());
    for ((p1, p2, colour), m) in lines.iter().zip(&segments) {
        assert!((p1.x - m.segment.start.x).abs() < 1e-6 && (p1.y - m.segment.start.y).abs() < 1e-6);
        assert!((p2.x - m.segment.end.x).abs() < 1e-6 && (p2.y - m.segment.end.y).abs() < 1e-6);
        assert!(colour.is_some());
    }
    // Lines of different walls (polylines) get different colours.
    assert_ne!(lines[0].2, lines[segments.len() - 1].2);
    assert_eq!(polyline_vertices.len(), trajectory.len());
    for (v, p) in polyline_vertices.iter().zip(&trajectory) {
        assert!((v.x - p.x).abs() < 1e-6 && (v.y - p.y).abs() < 1e-6);
    }
}
