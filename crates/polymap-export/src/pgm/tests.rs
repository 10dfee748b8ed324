use super::*;

fn params(resolution_m: f64) -> GridParams {
    GridParams {
        resolution_m,
        margin_m: 0.0,
        ..GridParams::default()
    }
}

#[test]
fn grid_covers_the_segments_with_margin() {
    let walls = [Segment::new(Vec2::new(0.0, 0.0), Vec2::new(4.0, 2.0))];
    let p = GridParams {
        resolution_m: 0.5,
        margin_m: 1.0,
        ..GridParams::default()
    };
    let grid = OccupancyGrid::build(&walls, std::iter::empty::<(Pose2, Vec<Vec2>)>(), &p)
        .expect("small grid");
    assert_eq!(grid.origin_m(), Vec2::new(-1.0, -1.0));
    assert_eq!((grid.width(), grid.height()), (12, 8));
    assert_eq!(grid.cell_at(Vec2::new(0.1, 0.02)), Some(Cell::Occupied));
    assert_eq!(grid.cell_at(Vec2::new(3.9, 1.98)), Some(Cell::Occupied));
    assert_eq!(grid.cell_at(Vec2::new(-5.0, 0.0)), None);
}

#[test]
fn rays_free_the_cells_before_the_hit_and_occupied_wins() {
    let walls = [
        Segment::new(Vec2::new(3.0, -1.0), Vec2::new(3.0, 1.0)),
        Segment::new(Vec2::new(1.0, -1.0), Vec2::new(1.0, -0.5)),
    ];
    let robot = Pose2::new(0.02, 0.03, std::f64::consts::PI);
    // The robot looks along -x: (-2.98, 0) in the robot frame is (3, 0.03) in the map, and
    // (-0.98, 0.73) is (1, -0.7), on the short wall.
    let rays = [(robot, vec![Vec2::new(-2.98, 0.0), Vec2::new(-0.98, 0.73)])];
    let p = GridParams {
        margin_m: 1.0,
        ..params(0.1)
    };
    let grid = OccupancyGrid::build(&walls, rays, &p).expect("small grid");
    assert_eq!(grid.cell_at(Vec2::new(0.05, 0.03)), Some(Cell::Free));
    assert_eq!(grid.cell_at(Vec2::new(2.85, 0.03)), Some(Cell::Free));
    assert_eq!(grid.cell_at(Vec2::new(3.0, 0.03)), Some(Cell::Occupied));
    assert_eq!(grid.cell_at(Vec2::new(0.51, -0.335)), Some(Cell::Free));
    assert_eq!(grid.cell_at(Vec2::new(1.0, -0.7)), Some(Cell::Occupied));
    assert_eq!(grid.cell_at(Vec2::new(2.0, 0.8)), Some(Cell::Unknown));
    let (unknown, free, occupied) = grid.counts();
    assert_eq!(unknown + free + occupied, grid.width() * grid.height());
    assert!(free >= 29 + 9 && occupied >= 20 + 5, "{free} {occupied}");
}

#[test]
fn a_grid_over_the_cap_is_refused_before_allocating() {
    let walls = [Segment::new(Vec2::new(-1e6, -1e6), Vec2::new(1e6, 1e6))];
    let err = OccupancyGrid::build(
        &walls,
        std::iter::empty::<(Pose2, Vec<Vec2>)>(),
        &params(0.05),
    )
    .expect_err("4e15 cells");
    assert!(matches!(err, ExportError::GridTooLarge { .. }), "{err}");
    assert!(err.to_string().contains("coarser resolution"));
}

#[test]
fn bad_parameters_and_points_are_handled() {
    let none = std::iter::empty::<(Pose2, Vec<Vec2>)>;
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let err = OccupancyGrid::build(&[], none(), &params(bad)).expect_err("bad resolution");
        assert!(err.to_string().contains("resolution_m"), "{err}");
    }
    let walls = [Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, f64::NAN))];
    let rays = [(Pose2::IDENTITY, vec![Vec2::NAN, Vec2::new(0.5, 0.5)])];
    let grid = OccupancyGrid::build(&walls, rays, &params(0.25)).expect("empty map grid");
    // Only the finite endpoint (0, 0) counts; the grid is one cell around it.
    assert_eq!(grid.origin_m(), Vec2::new(-0.125, -0.125));
    assert_eq!((grid.width(), grid.height()), (1, 1));
    assert_eq!(grid.cell_at(Vec2::new(0.1, 0.1)), Some(Cell::Free));
}

#[test]
fn pgm_rows_go_top_down() {
    let walls = [
        Segment::new(Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0)),
        Segment::new(Vec2::new(0.0, 0.0), Vec2::new(0.0, 0.2)),
    ];
    let grid = OccupancyGrid::build(
        &walls,
        std::iter::empty::<(Pose2, Vec<Vec2>)>(),
        &params(0.1),
    )
    .expect("small grid");
    let bytes = map_server::tests_support::pgm(&grid);
    let (w, h) = (grid.width(), grid.height());
    let header = format!("P5\n{w} {h}\n255\n");
    assert!(bytes.starts_with(header.as_bytes()));
    let pixels = &bytes[header.len()..];
    assert_eq!(pixels.len(), w * h);
    for (i, &v) in pixels.iter().enumerate() {
        let (col, row_from_top) = (i % w, i / w);
        let expected = match grid.cell(col, h - 1 - row_from_top) {
            Some(Cell::Occupied) => PIXEL_OCCUPIED,
            Some(Cell::Free) => PIXEL_FREE,
            _ => PIXEL_UNKNOWN,
        };
        assert_eq!(v, expected, "pixel {i}");
    }
    // The long wall is at the top of the map: the first PGM row is all black.
    assert!(pixels[..w].iter().all(|&v| v == PIXEL_OCCUPIED));
    assert_eq!(pixels[(h - 1) * w], PIXEL_OCCUPIED);
    assert_eq!(pixels[(h - 1) * w + w - 1], PIXEL_UNKNOWN);
}
