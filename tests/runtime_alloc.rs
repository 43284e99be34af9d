//! The runtime sampler never allocates per sample: a counting global allocator (per thread,
//! so other tests cannot interfere) sees no allocation across thousands of queries.

use glam::Vec3;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use warpfit::runtime::FittedGrid;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn sampling_does_not_allocate() {
    let g = FittedGrid::load(concat!(env!("CARGO_MANIFEST_DIR"), "/fits/tiny")).unwrap();
    let mut s = warpfit::sampling::Sampler::new(1, 2, 3);
    let queries: Vec<(Vec3, Vec3, f32)> = (0..4096)
        .map(|_| {
            let p = Vec3::new(s.next_1d() * 5.0 - 2.5, s.next_1d() * 3.0, s.next_1d() * 5.0 - 2.5);
            (p, warpfit::sampling::uniform_sphere(s.next_2d()), s.next_1d())
        })
        .collect();
    let mut out = vec![Vec3::ZERO; queries.len()];
    let (p, d, r): (Vec<Vec3>, Vec<Vec3>, Vec<f32>) = (
        queries.iter().map(|q| q.0).collect(),
        queries.iter().map(|q| q.1).collect(),
        queries.iter().map(|q| q.2).collect(),
    );
    // and read with the faces blend (`--blend faces`)
    let faces = g.clone().with_lookup(|_, blend, _| *blend = warpfit::warp::corrective::Blend::Faces);
    let before = ALLOCATIONS.with(|a| a.get());
    let mut acc = Vec3::ZERO;
    for g in [&g, &faces] {
        for &(p, d, r) in &queries {
            acc += g.specular(p, d, r) + g.irradiance(p, d);
        }
        g.specular_batch(&p, &d, &r, &mut out).unwrap();
        g.irradiance_batch(&p, &d, &mut out).unwrap();
    }
    let after = ALLOCATIONS.with(|a| a.get());
    assert!(acc.is_finite());
    assert_eq!(after - before, 0, "allocations during sampling");
}
