//! Writes `data/scenes/town.toml`, the built-in open level: a town of 400 × 400 m, 20 m
//! tall at most, on an 8 × 8 street grid (40 m blocks, 10 m streets), its four middle
//! blocks a plaza with a covered market (a roof on 15 columns over market stalls), four
//! enterable buildings facing the plaza (walls 0.3 m thick, a door, a window, a partition
//! with a doorway, a lamp in each room), and on the other blocks' lots 204 closed buildings
//! of 4–20 m and 32 hedged parks, under sun and sky.
//!
//!     cargo run --release --example town > data/scenes/town.toml
//!
//! The layout comes from a fixed seed, so the file is the same on every machine.

use std::fmt::Write;

/// Half the town's side (m).
const HALF: f32 = 200.0;
/// A block's side and a street's width (m).
const BLOCK: f32 = 40.0;
const STREET: f32 = 10.0;
/// Blocks per side.
const BLOCKS: usize = 8;
/// The tallest building (m); the level's height.
const TALLEST: f32 = 20.0;

/// A 32-bit linear congruential generator (Numerical Recipes' constants): enough to vary
/// heights and colours, and the same everywhere.
struct Lcg(u32);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (self.0 >> 8) as f32 / (1u32 << 24) as f32
    }
}

#[derive(Default)]
struct Toml {
    geometry: String,
    lights: String,
    boxes: usize,
}

impl Toml {
    fn boxed(&mut self, min: [f32; 3], max: [f32; 3], albedo: [f32; 3]) {
        self.boxes += 1;
        let _ = writeln!(
            self.geometry,
            "[[geometry]]\ntype = \"box\"\nmin = {}\nmax = {}\nmaterial = {{ albedo = {} }}\n",
            v(min),
            v(max),
            v(albedo)
        );
    }

    fn column(&mut self, x: f32, z: f32, radius: f32, height: f32) {
        let _ = writeln!(
            self.geometry,
            "[[geometry]]\ntype = \"column\"\nbase = {}\nradius = {radius}\nheight = {height}\nsegments = 12\nmaterial = {{ albedo = [0.72, 0.7, 0.66] }}\n",
            v([x, 0.0, z])
        );
    }

    fn lamp(&mut self, p: [f32; 3]) {
        let _ = writeln!(
            self.lights,
            "[[sphere_lights]]\nposition = {}\nradius = 0.15\nradiance = [60.0, 50.0, 38.0]\n",
            v(p)
        );
    }
}

fn v(a: [f32; 3]) -> String {
    format!("[{}, {}, {}]", r(a[0]), r(a[1]), r(a[2]))
}

/// Two decimals, without trailing zeros beyond one.
fn r(x: f32) -> String {
    let s = format!("{:.2}", x);
    let s = s.trim_end_matches('0');
    if s.ends_with('.') { format!("{s}0") } else { s.to_string() }
}

/// A block's lower corner along one axis.
fn block_start(i: usize) -> f32 {
    -HALF + STREET / 2.0 + i as f32 * (BLOCK + STREET)
}

/// A one-room-deep building of two rooms on the lot `[x0, x1] × [z0, z1]`, its door in the
/// wall facing `+x` (`door_plus_x`) or `-x`, a window opposite, a partition with a doorway
/// across the middle and a lamp under the ceiling of each room.
fn enterable(t: &mut Toml, x0: f32, x1: f32, z0: f32, z1: f32, door_plus_x: bool, albedo: [f32; 3]) {
    const H: f32 = 6.0;
    const W: f32 = 0.3;
    let zm = 0.5 * (z0 + z1);
    // the two walls along x, whole
    t.boxed([x0, 0.0, z0], [x1, H, z0 + W], albedo);
    t.boxed([x0, 0.0, z1 - W], [x1, H, z1], albedo);
    // the door wall and the window wall, each around its opening
    let (door_x, window_x) = if door_plus_x { (x1 - W, x0) } else { (x0, x1 - W) };
    let (dz0, dz1) = (zm - 5.0, zm - 2.6);
    t.boxed([door_x, 0.0, z0 + W], [door_x + W, H, dz0], albedo);
    t.boxed([door_x, 0.0, dz1], [door_x + W, H, z1 - W], albedo);
    t.boxed([door_x, 3.0, dz0], [door_x + W, H, dz1], albedo);
    let (wz0, wz1) = (zm + 2.0, zm + 5.0);
    t.boxed([window_x, 0.0, z0 + W], [window_x + W, H, wz0], albedo);
    t.boxed([window_x, 0.0, wz1], [window_x + W, H, z1 - W], albedo);
    t.boxed([window_x, 0.0, wz0], [window_x + W, 1.0, wz1], albedo);
    t.boxed([window_x, 2.8, wz0], [window_x + W, H, wz1], albedo);
    // the roof
    t.boxed([x0, H - W, z0], [x1, H, z1], [0.45, 0.4, 0.38]);
    // the partition across the middle (along x), a 1.2 m doorway in it
    let xm = 0.5 * (x0 + x1);
    t.boxed([x0 + W, 0.0, zm - 0.1], [xm - 0.6, H - W, zm + 0.1], [0.8, 0.78, 0.74]);
    t.boxed([xm + 0.6, 0.0, zm - 0.1], [x1 - W, H - W, zm + 0.1], [0.8, 0.78, 0.74]);
    t.boxed([xm - 0.6, 2.4, zm - 0.1], [xm + 0.6, H - W, zm + 0.1], [0.8, 0.78, 0.74]);
    // a table in the door's room
    t.boxed([xm - 1.5, 0.0, zm - 5.0], [xm + 1.5, 0.8, zm - 3.5], [0.55, 0.4, 0.3]);
    t.lamp([xm, H - 1.0, 0.5 * (z0 + zm)]);
    t.lamp([xm, H - 1.0, 0.5 * (zm + z1)]);
}

fn main() {
    let mut t = Toml::default();
    let mut rng = Lcg(20_261_129);
    // the ground, the streets' asphalt (a slab, so no ray leaves under the town)
    t.boxed([-HALF, -1.0, -HALF], [HALF, 0.0, HALF], [0.3, 0.3, 0.3]);
    let plaza = |i: usize| i == 3 || i == 4;
    for i in 0..BLOCKS {
        for j in 0..BLOCKS {
            if plaza(i) && plaza(j) {
                continue;
            }
            let (bx, bz) = (block_start(i), block_start(j));
            // an enterable building on the lot by the street to the plaza, one per side of it
            let enterable_lot = match (i, j) {
                (2, 3) => Some(((1, 0), true)),
                (5, 4) => Some(((0, 1), false)),
                (3, 2) => Some(((1, 1), true)),
                (4, 5) => Some(((0, 0), false)),
                _ => None,
            };
            // a sidewalk kerb round the block
            t.boxed([bx, 0.0, bz], [bx + BLOCK, 0.15, bz + BLOCK], [0.55, 0.53, 0.5]);
            for (lx, lz) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                let (x0, z0) = (bx + 1.0 + lx as f32 * 20.0, bz + 1.0 + lz as f32 * 20.0);
                let (x1, z1) = (x0 + 18.0, z0 + 18.0);
                let tint = 0.5 + 0.35 * rng.next();
                let albedo = [tint + 0.08 * rng.next(), tint, tint - 0.08 * rng.next()];
                let h = 4.0 + (TALLEST - 4.0) * rng.next() * rng.next().sqrt();
                if let Some((lot, door_plus_x)) = enterable_lot
                    && lot == (lx, lz)
                {
                    enterable(&mut t, x0, x1, z0, z1, door_plus_x, albedo);
                    continue;
                }
                if rng.next() < 0.12 {
                    // a small park: a hedge round the lot
                    t.boxed([x0, 0.15, z0], [x1, 1.2, z0 + 0.6], [0.2, 0.35, 0.15]);
                    t.boxed([x0, 0.15, z1 - 0.6], [x1, 1.2, z1], [0.2, 0.35, 0.15]);
                    continue;
                }
                t.boxed([x0, 0.15, z0], [x1, h, z1], albedo);
            }
        }
    }
    // the plaza's covered market: a roof on three rows of five columns, stalls beneath
    t.boxed([-21.0, 7.5, -12.0], [21.0, 8.0, 12.0], [0.5, 0.42, 0.36]);
    for x in [-18.0, -9.0, 0.0, 9.0, 18.0] {
        for z in [-10.0, 0.0, 10.0] {
            t.column(x, z, 0.35, 7.5);
        }
    }
    for x in [-13.5, -4.5, 4.5, 13.5] {
        for z in [-5.0, 5.0] {
            t.boxed([x - 1.5, 0.0, z - 0.75], [x + 1.5, 0.9, z + 0.75], [0.6, 0.45, 0.3]);
        }
    }
    // a fountain basin in the plaza's south half
    t.boxed([-3.0, 0.0, 26.0], [3.0, 0.6, 32.0], [0.7, 0.7, 0.72]);

    print!(
        "# The built-in open level, written by `cargo run --release --example town`: a town of\n\
         # 400 x 400 m and 20 m at most, on an 8 x 8 street grid (40 m blocks, 10 m streets),\n\
         # the four middle blocks a plaza with a covered market, four enterable two-room\n\
         # buildings facing the plaza (a door, a window, a lamp per room) and closed buildings\n\
         # of 4-20 m on the other lots ({} boxes, 15 columns), under sun and sky. Its grid at an\n\
         # interior's 1 m would be 400 x 20 x 400 = 3.2M cells; the one here is 10 m.\n\
         name = \"town\"\nseed = 1\nbounces = 1\n\n\
         [probe]\nposition = [0.0, 2.0, -20.0]\nresolution = 256\nsamples_per_texel = 32\n\n\
         [probes]\nauto = true\n\n\
         [grid]\nmin = [-199.9, 0.1, -199.9]\nmax = [199.9, 19.9, 199.9]\ncounts = [40, 2, 40]\n\n\
         [sky]\nzenith = [0.3, 0.5, 1.0]\nhorizon = [0.85, 0.9, 1.0]\nground = [0.2, 0.18, 0.15]\n\n\
         [sun]\ndirection = [0.35, 0.8, 0.45]\nangular_radius_deg = 0.5\nirradiance = [9.0, 8.5, 7.5]\n\n",
        t.boxes
    );
    print!("{}", t.lights);
    print!("{}", t.geometry);
}
