use super::{deepest_stack, Crossing};
use glam::Vec3;

/// A crossing of triangle `triangle` at `t`, facing `normal`, in its interior or
/// not.
fn crossing(t: f32, triangle: u32, normal: Vec3, interior: bool) -> Crossing {
    Crossing {
        t,
        geometry: 0,
        triangle,
        alpha: false,
        normal,
        interior,
    }
}

#[test]
fn the_deepest_stack_is_of_parallel_interior_crossings_within_the_tolerance() {
    let (up, down, side) = (Vec3::Z, -Vec3::Z, Vec3::X);
    let stack = |crossed: &[Crossing]| deepest_stack(&mut crossed.to_vec(), 0.1);
    // Three parallel layers (one facing the other way, as in a fold), given out of
    // order: a stack, nearest first.
    let three = [
        crossing(1.05, 7, up, true),
        crossing(1.0, 3, down, true),
        crossing(1.08, 5, up, true),
    ];
    assert_eq!(stack(&three), vec![(0, 3), (0, 7), (0, 5)]);
    // Through an edge (a neighbour at the same depth), not a layer.
    let mut edge = three;
    edge[0].interior = false;
    assert_eq!(stack(&edge), vec![]);
    // Across the others: a bump, not a layer.
    let mut bump = three;
    bump[2].normal = side;
    assert_eq!(stack(&bump), vec![]);
    // Too far behind.
    let mut behind = three;
    behind[2].t = 1.2;
    assert_eq!(stack(&behind), vec![]);
    // Two stacks: the deeper one, here the second; the first layer of a window
    // sets the direction.
    let mut two: Vec<Crossing> = (0..3)
        .map(|k| crossing(k as f32 * 0.01, k, up, true))
        .collect();
    two.push(crossing(0.02, 90, side, true));
    two.extend((10..14).map(|k| crossing(5.0 + k as f32 * 0.01, k, down, true)));
    two.push(crossing(5.25, 91, up, true));
    assert_eq!(stack(&two), (10..14).map(|k| (0, k)).collect::<Vec<_>>());
}
