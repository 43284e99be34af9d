//! How many cells sparse bricks keep over a scene's grid box at a finest cell size, by each
//! splitting rule of `warpfit::bake::bricks` (docs/volumes.md):
//!
//!     cargo run --release --example bricks -- data/scenes/town.toml 1.0
//!
//! Prints one row per rule: the bricks kept per level (finest first), the cells they hold,
//! their share of the uniform grid's at the finest size, the bricks dropped inside geometry
//! and the seconds the plan took.

use glam::Vec3;
use std::time::Instant;
use warpfit::bake::bricks::{BrickPlan, Rule, plan};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    anyhow::ensure!(args.len() == 3, "usage: bricks SCENE.toml FINEST_CELL_SIZE");
    let scene = warpfit::scene::Scene::load(std::path::Path::new(&args[1]))?;
    let finest: f32 = args[2].parse().map_err(|e| anyhow::anyhow!("{}: {e}", args[2]))?;
    let tracer = warpfit::trace::Tracer::new(&scene);
    let g = &scene.config.grid;
    let (min, max) = (Vec3::from_array(g.min), Vec3::from_array(g.max));
    println!("| rule | bricks kept (1× / 3× / 9× cells) | cells | of the uniform grid's | dropped inside | s |");
    println!("|---|---|---:|---:|---:|---:|");
    let rules = [
        ("near geometry (APV)", Rule::NearGeometry),
        ("seen distance, nearest point, cell > ½ distance (check's)", Rule::CHECK),
        ("seen distance, nearest point, cell > distance", Rule::SeenDistance { quantile: 0.0, factor: 1.0 }),
        ("seen distance, lower-quartile point, cell > ½ distance", Rule::SeenDistance { quantile: 0.25, factor: 2.0 }),
        ("seen distance, median point, cell > ½ distance", Rule::SeenDistance { quantile: 0.5, factor: 2.0 }),
    ];
    for (name, rule) in rules {
        let t = Instant::now();
        let p: BrickPlan = plan(
            &scene,
            &tracer,
            (min, max),
            finest,
            warpfit::jobs::check::BRICK_LEVELS,
            rule,
            g.inside_backface_fraction,
        );
        let kept: Vec<String> = p.kept.iter().map(u64::to_string).collect();
        println!(
            "| {name} | {} | {} | {:.1}% of {} | {} | {:.1} |",
            kept.join(" / "),
            p.cells(),
            100.0 * p.share(),
            p.uniform_cells,
            p.solid.iter().sum::<u64>(),
            t.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
