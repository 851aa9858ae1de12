//! The ray tracer's BVH built on the GPU (issue 32): proxy boxes against the CPU reference's,
//! Morton order, Karras' tree against its CPU twin exactly, and boxes bottom up (each node the
//! union of its children's, every leaf reached once).

mod common;

use glam::Vec3;
use rara::raytrace::bvh::{karras_tree, BvhBuild, BvhReadback};
use rara::reference::raytrace::proxy_bounds;
use rara::synth::Rng;
use rara::{Renderer, Scene};

/// Flat and volumetric Gaussians, some too faint for any proxy, some sharing a centre (equal
/// Morton codes).
fn scene(count: usize, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut s = Scene::default();
    for i in 0..count {
        let mut scale = Vec3::new(
            rng.range(0.01, 0.1),
            rng.range(0.01, 0.1),
            rng.range(0.01, 0.1),
        );
        if i % 3 == 0 {
            scale[i % 3] = 0.0;
        }
        let mean = if i % 17 == 5 {
            Vec3::splat(0.25)
        } else {
            Vec3::new(
                rng.range(-2.0, 2.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 3.0),
            )
        };
        let opacity = if i % 23 == 0 {
            0.002
        } else {
            rng.range(0.05, 0.99)
        };
        s.push(mean, opacity, scale, rng.rotation(), &[0.0, 0.0, 0.0]);
    }
    s
}

fn check(name: &str, scene: &Scene, bvh: &BvhReadback) {
    let n = scene.len();
    // Proxies against the CPU reference's (f64 there, f32 here).
    for i in 0..n {
        let b = &bvh.boxes[i];
        match proxy_bounds(scene, i, rara::mesh::DEFAULT_Q) {
            None => assert!(b.is_empty(), "{name}: Gaussian {i} has a box {b:?}"),
            Some(r) => {
                let size = (r.hi - r.lo).max_element().max(1e-6);
                for k in 0..3 {
                    assert!(
                        ((b.lo[k] as f64) - r.lo[k]).abs() <= 1e-4 * size + 1e-6,
                        "{name} {i} lo"
                    );
                    assert!(
                        ((b.hi[k] as f64) - r.hi[k]).abs() <= 1e-4 * size + 1e-6,
                        "{name} {i} hi"
                    );
                }
            }
        }
    }
    // Morton order: sorted codes, a permutation, empty boxes last.
    assert!(
        bvh.codes.windows(2).all(|w| w[0] <= w[1]),
        "{name}: codes not sorted"
    );
    let mut seen = vec![false; n];
    for &g in &bvh.order {
        assert!(!seen[g as usize], "{name}: Gaussian {g} twice");
        seen[g as usize] = true;
    }
    for (k, &g) in bvh.order.iter().enumerate() {
        assert_eq!(
            bvh.boxes[g as usize].is_empty(),
            bvh.codes[k] == 1 << 30,
            "{name}: code of {g}"
        );
    }
    if n < 2 {
        return;
    }
    // The tree, exactly as the CPU twin builds it from the same codes.
    let tree = karras_tree(&bvh.codes);
    for (i, &(l, r)) in tree.iter().enumerate() {
        assert_eq!(bvh.nodes[i].children(), (l, r), "{name}: node {i}");
        assert_eq!(bvh.parents[l as usize], i as u32);
        assert_eq!(bvh.parents[r as usize], i as u32);
    }
    assert_eq!(bvh.parents[0], u32::MAX);
    // Every inner node was reached by both of its children's walkers.
    assert!(
        bvh.arrivals.iter().all(|&a| a == 2),
        "{name}: arrivals {:?}",
        bvh.arrivals.iter().find(|&&a| a != 2)
    );
    // Boxes bottom up: leaves hold their Gaussian's box, inner nodes the union of their
    // children's (min and max are exact in f32), and a walk from the root meets every leaf once.
    let leaves = n - 1;
    for k in 0..n {
        let node = &bvh.nodes[leaves + k];
        let g = bvh.order[k];
        assert_eq!(node.left, g, "{name}: leaf {k}");
        assert_eq!(node.lo, bvh.boxes[g as usize].lo);
        assert_eq!(node.hi, bvh.boxes[g as usize].hi);
    }
    let mut reached = vec![0u32; n];
    let mut stack = vec![0u32];
    let mut depth_max = 0;
    let mut depths = vec![0usize; 2 * n - 1];
    while let Some(node) = stack.pop() {
        let i = node as usize;
        depth_max = depth_max.max(depths[i]);
        if i >= leaves {
            reached[i - leaves] += 1;
            continue;
        }
        let (l, r) = bvh.nodes[i].children();
        for c in [l, r] {
            let (p, ch) = (&bvh.nodes[i], &bvh.nodes[c as usize]);
            for k in 0..3 {
                if !ch.is_empty() {
                    assert!(
                        p.lo[k] <= ch.lo[k] && p.hi[k] >= ch.hi[k],
                        "{name}: node {i} misses child {c}"
                    );
                }
            }
            depths[c as usize] = depths[i] + 1;
            stack.push(c);
        }
        let (a, b) = (&bvh.nodes[l as usize], &bvh.nodes[r as usize]);
        for k in 0..3 {
            assert_eq!(
                bvh.nodes[i].lo[k],
                a.lo[k].min(b.lo[k]),
                "{name}: node {i} lo"
            );
            assert_eq!(
                bvh.nodes[i].hi[k],
                a.hi[k].max(b.hi[k]),
                "{name}: node {i} hi"
            );
        }
    }
    assert!(
        reached.iter().all(|&r| r == 1),
        "{name}: a leaf reached {:?} times",
        reached.iter().find(|&&r| r != 1)
    );
    eprintln!(
        "  {name}: {n} Gaussians, {} nodes, depth {depth_max}",
        2 * n - 1
    );
}

/// Sizes around the edges (1, 2, 3 Gaussians, a workgroup +-1) and a large scene, with equal
/// codes among them; and a real scene, flat and not, when present.
#[test]
fn gpu_bvh_matches_its_twin() {
    let ctx = common::context();
    let renderer = Renderer::new(&ctx).unwrap();
    let build = BvhBuild::new(&ctx).unwrap();
    let mut cases: Vec<(String, Scene)> = [1, 2, 3, 255, 256, 257, 5000, 70000]
        .iter()
        .map(|&n| (format!("synthetic {n}"), scene(n, n as u64)))
        .collect();
    if let Some((ply, _)) = common::real_scene("plant_capture_sh0") {
        eprintln!("real-scene case 'plant_capture_sh0' RAN");
        let plant = rara::ply::load_ply(&ply).unwrap().0;
        cases.push(("plant flat".into(), plant.flattened()));
        cases.push(("plant".into(), plant));
    }
    for (name, s) in &cases {
        let gpu = renderer.upload(s).unwrap();
        let bvh = build
            .build_and_read(&ctx, &gpu, rara::mesh::DEFAULT_Q as f32)
            .unwrap();
        check(name, s, &bvh);
        // Deterministic: a second build gives the same nodes.
        let again = build
            .build_and_read(&ctx, &gpu, rara::mesh::DEFAULT_Q as f32)
            .unwrap();
        assert_eq!(
            bvh.nodes, again.nodes,
            "{name}: the build is not deterministic"
        );
    }
    common::assert_no_validation_messages(&ctx);
}
