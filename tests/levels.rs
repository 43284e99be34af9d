//! A studio's own level: glTF and OBJ as tools export them (textures, doubleSided, lights,
//! Z-up and centimetres), the scene check, `warpfit init`, and honest failures.

mod common;
use common::*;
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::Command;
use warpfit::scene::Scene;
use warpfit::trace::{Renderer, Tracer};

fn warpfit(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_warpfit")).args(args).current_dir(repo()).output().expect("warpfit runs")
}

fn text(o: &std::process::Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

fn write_scene(dir: &Path, body: &str) -> PathBuf {
    let p = dir.join("scene.toml");
    std::fs::write(&p, format!("{HEADER}\n{body}")).unwrap();
    p
}

/// A glTF quad (two triangles, y = 0, x and z in [-1, 1], facing +y) with texture
/// coordinates u = (x+1)/2, v = (z+1)/2 and a base-colour texture from `image_uri`.
fn textured_quad(image_uri: &str) -> String {
    quad_gltf(
        r#""materials":[{"pbrMetallicRoughness":{"baseColorFactor":[1,1,1,1],"baseColorTexture":{"index":0}}}],"textures":[{"source":0}],"images":[{"uri":"IMAGE"}],"#
            .replace("IMAGE", image_uri)
            .as_str(),
        r#""nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"#,
    )
}

/// The quad with `materials` (root members for materials, textures, images) and `nodes`
/// (root members for nodes and scenes, and any extensions).
fn quad_gltf(materials: &str, nodes: &str) -> String {
    use base64::Engine as _;
    let pos: [[f32; 3]; 4] = [[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [1.0, 0.0, 1.0], [-1.0, 0.0, 1.0]];
    let uv: [[f32; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let idx: [u32; 6] = [0, 2, 1, 0, 3, 2];
    let mut buf = Vec::new();
    for p in pos {
        for c in p {
            buf.extend(c.to_le_bytes());
        }
    }
    for t in uv {
        for c in t {
            buf.extend(c.to_le_bytes());
        }
    }
    for i in idx {
        buf.extend(i.to_le_bytes());
    }
    let data = base64::engine::general_purpose::STANDARD.encode(&buf);
    format!(
        r#"{{"asset":{{"version":"2.0"}},{nodes}"scene":0,
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1}},"indices":2,"material":0}}]}}],
{materials}
"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{data}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":32}},{{"buffer":0,"byteOffset":80,"byteLength":24}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-1,0,-1],"max":[1,0,1]}},
{{"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"}},{{"bufferView":2,"componentType":5125,"count":6,"type":"SCALAR"}}]}}"#,
        buf.len()
    )
}

/// A 2×1 PNG: left texel red, right texel green (sRGB 255 = linear 1).
fn two_texel_png(path: &Path) {
    let img =
        image::RgbImage::from_fn(2, 1, |x, _| if x == 0 { image::Rgb([255, 0, 0]) } else { image::Rgb([0, 255, 0]) });
    img.save(path).unwrap();
}

/// Mean radiance of the quad seen straight down at (x, z): under a white upper sky (one
/// bounce, which is how the sky lights surfaces) it is the albedo at that point.
fn radiance_of_quad_at(scene: &Scene, x: f32, z: f32) -> Vec3 {
    let tracer = Tracer::new(scene);
    let r = Renderer::new(scene, &tracer);
    let mut rays = 0;
    let mut sum = Vec3::ZERO;
    for k in 0..256 {
        let mut s = warpfit::sampling::Sampler::new(1, 2, k);
        sum += r.sample(Vec3::new(x, 1.0, z), Vec3::NEG_Y, &mut s, &mut rays).radiance;
    }
    sum / 256.0
}

const WHITE_SKY: &str =
    "bounces = 1\n[sky]\nzenith = [1.0, 1.0, 1.0]\nhorizon = [1.0, 1.0, 1.0]\nground = [0.0, 0.0, 0.0]\n";

#[test]
fn base_colour_textures_are_sampled_at_the_hit() {
    let d = tmp_dir("texture");
    two_texel_png(&d.join("rg.png"));
    std::fs::write(d.join("quad.gltf"), textured_quad("rg.png")).unwrap();
    let scene = Scene::parse(
        &format!("{WHITE_SKY}{HEADER}\n[[geometry]]\ntype = \"gltf\"\npath = \"quad.gltf\"\n"),
        &d.join("scene.toml"),
    )
    .unwrap();
    assert_eq!(scene.textures.len(), 1);
    assert_eq!(scene.inputs.len(), 2, "the glTF and its image are inputs: {:?}", scene.inputs);
    let left = radiance_of_quad_at(&scene, -0.5, 0.0); // u = 0.25: the red texel's centre
    let right = radiance_of_quad_at(&scene, 0.5, 0.0); // u = 0.75: the green texel's centre
    assert!(left.x > 0.3 && left.y < 0.05 && left.z < 0.05, "{left}");
    assert!(right.y > 0.3 && right.x < 0.05 && right.z < 0.05, "{right}");
    assert!((left.x - right.y).abs() < 0.05 * left.x, "the same irradiance on both: {left} {right}");
}

#[test]
fn a_missing_texture_warns_and_uses_the_factor() {
    let d = tmp_dir("missing-texture");
    std::fs::write(d.join("quad.gltf"), textured_quad("textures/not-here.png")).unwrap();
    let scene = Scene::parse(
        &format!("{WHITE_SKY}{HEADER}\n[[geometry]]\ntype = \"gltf\"\npath = \"quad.gltf\"\n"),
        &d.join("scene.toml"),
    )
    .expect("a missing image is not an error");
    assert!(scene.textures.is_empty());
    assert!(scene.materials.iter().all(|m| m.texture.is_none()));
    let c = radiance_of_quad_at(&scene, 0.0, 0.0);
    assert!((c.x - c.y).abs() < 1e-3 && c.x > 0.3, "white factor: {c}");
}

#[test]
fn a_point_light_from_the_file_lights_as_its_candela_say() {
    // a 10 cd point light 1 m above the quad's centre; the quad is white: L = (1/π) · I / d²
    let d = tmp_dir("point-light");
    let gltf = quad_gltf(
        r#""materials":[{"pbrMetallicRoughness":{"baseColorFactor":[1,1,1,1]}}],"#,
        r#""extensionsUsed":["KHR_lights_punctual"],"extensions":{"KHR_lights_punctual":{"lights":[{"type":"point","intensity":10.0}]}},
"nodes":[{"mesh":0},{"translation":[0,1,0],"extensions":{"KHR_lights_punctual":{"light":0}}}],"scenes":[{"nodes":[0,1]}],"#,
    );
    std::fs::write(d.join("quad.gltf"), gltf).unwrap();
    let scene = Scene::parse(
        &format!("bounces = 0\n{HEADER}\n[[geometry]]\ntype = \"gltf\"\npath = \"quad.gltf\"\n"),
        &d.join("scene.toml"),
    )
    .unwrap();
    assert_eq!(scene.lights.sphere_lights.len(), 1);
    let tracer = Tracer::new(&scene);
    let r = Renderer::new(&scene, &tracer);
    let mut rays = 0;
    let mut sum = 0.0f64;
    for k in 0..512 {
        let mut s = warpfit::sampling::Sampler::new(3, 4, k);
        sum += r.sample(Vec3::new(0.0, 0.5, 0.0), Vec3::NEG_Y, &mut s, &mut rays).radiance.x as f64;
    }
    let got = sum / 512.0;
    let want = 10.0 / std::f64::consts::PI;
    assert!((got - want).abs() < 0.02 * want, "{got} vs {want}");
}

#[test]
fn a_double_sided_solid_flags_exactly_the_cells_inside_it() {
    // a two-sided box [−0.45, 0.45]³ + (0, 1, 0) in a 4×4×4 grid over [−1, 1]×[0, 2]×[−1, 1]:
    // the 8 cells whose centres are at ±0.25 inside it, no others
    let d = tmp_dir("double-sided");
    let body = "[sky]\ncolor = [1.0, 1.0, 1.0]\n[[geometry]]\ntype = \"box\"\nmin = [-0.45, 0.55, -0.45]\nmax = [0.45, 1.45, 0.45]\nmaterial = { two_sided = true }\n";
    let text = format!("{HEADER}\n{body}")
        .replace("counts = [2, 2, 2]", "counts = [4, 4, 4]")
        .replace("depth_samples = 1", "depth_samples = 4");
    let p = d.join("box.toml");
    std::fs::write(&p, text).unwrap();
    let scene = Scene::load(&p).unwrap();
    let tracer = Tracer::new(&scene);
    let bake = warpfit::bake::bake(&scene, &tracer, &warpfit::progress::Progress::quiet());
    let g = &bake.grid;
    for cell in 0..g.geometry.cell_count() {
        let c = g.geometry.cell_centre(cell);
        let inside = c.x.abs() < 0.45 && (c.y - 1.0).abs() < 0.45 && c.z.abs() < 0.45;
        assert_eq!(g.inside[cell], inside, "cell {cell} at {c}");
    }
    assert_eq!(g.inside.iter().filter(|x| **x).count(), 8);
}

#[test]
fn up_axis_and_units_equal_a_hand_transform() {
    let d = tmp_dir("z-up");
    // an L-shaped mesh in centimetres, Z up
    std::fs::write(
        d.join("l.obj"),
        "v 0 0 0\nv 100 0 0\nv 100 0 200\nv 0 0 200\nv 0 50 0\nv 100 50 0\nf 1 2 3\nf 1 3 4\nf 1 5 6\nf 1 6 2\n",
    )
    .unwrap();
    // top-level keys before the tables (after [grid] they would belong to it)
    let keys = d.join("keys.toml");
    std::fs::write(
        &keys,
        format!("up_axis = \"z\"\nunits = 0.01\n{HEADER}\n[[geometry]]\ntype = \"obj\"\npath = \"l.obj\"\n"),
    )
    .unwrap();
    let keyed = Scene::load(&keys).unwrap();
    let hand = write_scene(
        &d,
        "[[geometry]]\ntype = \"obj\"\npath = \"l.obj\"\ntransform = { rotate_deg = [-90.0, 0.0, 0.0], scale = [0.01, 0.01, 0.01] }\n",
    );
    let hand = Scene::load(&hand).unwrap();
    assert_eq!(keyed.triangles.len(), hand.triangles.len());
    for k in 0..hand.triangles.len() {
        for (a, b) in [(keyed.triangles.v0[k], hand.triangles.v0[k]), (keyed.triangles.v2[k], hand.triangles.v2[k])] {
            assert!((a - b).length() < 1e-5, "triangle {k}: {a} vs {b}");
        }
    }
    // Z up: the mesh's 200 cm along Z is now 2 m of height, its 50 cm along Y runs along −Z
    let (lo, hi) = keyed.bounds();
    assert!((hi.y - 2.0).abs() < 1e-5 && (lo.z + 0.5).abs() < 1e-5, "{lo} {hi}");
}

#[test]
fn a_dark_scene_and_a_probe_in_a_wall_are_errors() {
    let d = tmp_dir("check");
    let room = "[[geometry]]\ntype = \"room\"\nmin = [-1.0, 0.0, -1.0]\nmax = [1.0, 2.0, 1.0]\n";
    let dark = write_scene(&d, room);
    let o = warpfit(&["check", "--scene", &dark.to_string_lossy()]);
    assert!(!o.status.success());
    assert!(text(&o).contains("no light"), "{}", text(&o));
    // a probe inside a solid block
    let p = d.join("wall.toml");
    let body = format!(
        "{HEADER}\n[sky]\ncolor = [1.0, 1.0, 1.0]\n{room}[[geometry]]\ntype = \"box\"\nmin = [-0.5, 0.5, -0.5]\nmax = [0.5, 1.5, 0.5]\n"
    );
    std::fs::write(&p, body).unwrap();
    let o = warpfit(&["check", "--scene", &p.to_string_lossy()]);
    assert!(!o.status.success());
    assert!(text(&o).contains("probe.position") && text(&o).contains("inside geometry"), "{}", text(&o));
    // the same rays are what one-sided surfaces of mixed winding show: the cure is named too
    assert!(text(&o).contains("two_sided = true"), "{}", text(&o));
    // and `fit` refuses it before baking
    let out = d.join("out");
    let o = warpfit(&["fit", "--scene", &p.to_string_lossy(), "--out", &out.to_string_lossy()]);
    assert!(!o.status.success() && text(&o).contains("inside geometry"), "{}", text(&o));
    assert!(!out.exists());
}

#[test]
fn init_writes_scenes_that_check_accepts_and_fit() {
    let d = tmp_dir("init");
    for (mesh, cell) in [("gallery.gltf", "1.5"), ("cornell_blocks.obj", "0.2")] {
        let src = repo().join("data/meshes").join(mesh);
        let o = warpfit(&["init", "--mesh", &src.to_string_lossy(), "--cell-size", cell]);
        assert!(o.status.success(), "{}", text(&o));
        let scene_text = String::from_utf8(o.stdout).unwrap();
        assert!(scene_text.contains("# Probe A"), "{scene_text}");
        // the gallery's second room is hidden from probe A: init places probes for it
        if mesh == "gallery.gltf" {
            assert!(scene_text.contains("[probes]\npositions = [["), "{scene_text}");
        }
        let scene = d.join(format!("{mesh}.toml"));
        std::fs::write(&scene, &scene_text).unwrap();
        let o = warpfit(&["check", "--scene", &scene.to_string_lossy()]);
        assert!(o.status.success(), "{mesh}: {}", text(&o));
        let out = d.join(format!("{mesh}-fit"));
        let o = warpfit(&[
            "--quiet",
            "fit",
            "--scene",
            &scene.to_string_lossy(),
            "--out",
            &out.to_string_lossy(),
            "--train-positions",
            "2",
            "--train-dirs",
            "16",
        ]);
        assert!(o.status.success(), "{mesh}: {}", text(&o));
        warpfit::runtime::FittedGrid::load(&out).unwrap();
    }
}

#[test]
fn check_says_each_warning_once_and_names_no_file_it_did_not_read() {
    let d = tmp_dir("check-once");
    // a floor with one duplicate and one degenerate triangle, under a ceiling
    let obj = "v -2 0 -2\nv 2 0 -2\nv 2 0 2\nv -2 0 2\nv -2 3 -2\nv 2 3 -2\nv 2 3 2\nv -2 3 2\n\
               f 1 3 2\nf 1 4 3\nf 1 4 3\nf 1 1 2\nf 5 6 7\nf 5 7 8\n";
    std::fs::write(d.join("room.obj"), obj).unwrap();
    let o = warpfit(&["init", "--mesh", &d.join("room.obj").to_string_lossy()]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!text(&o).contains(".init.toml"), "init names a file it never wrote:\n{}", text(&o));
    let scene = d.join("room.toml");
    std::fs::write(&scene, &o.stdout).unwrap();
    let o = warpfit(&["check", "--scene", &scene.to_string_lossy()]);
    let all = text(&o);
    for what in ["degenerate", "duplicate"] {
        assert_eq!(all.matches(what).count(), 2, "once in the summary line and once as a warning:\n{all}");
    }
}

/// A closed box room, `w` wide and deep and `h` tall, its faces seen from inside, as OBJ.
fn closed_room_obj(w: f32, h: f32) -> String {
    let v = |x: f32, y: f32, z: f32| format!("v {x} {y} {z}\n");
    let mut s = String::new();
    for (x, y, z) in
        [(0., 0., 0.), (w, 0., 0.), (w, 0., w), (0., 0., w), (0., h, 0.), (w, h, 0.), (w, h, w), (0., h, w)]
    {
        s += &v(x, y, z);
    }
    // inward-facing quads (counter-clockwise seen from inside), as triangles
    for [a, b, c, d] in [[1, 4, 3, 2], [5, 6, 7, 8], [1, 2, 6, 5], [3, 4, 8, 7], [2, 3, 7, 6], [4, 1, 5, 8]] {
        s += &format!("f {a} {b} {c}\nf {a} {c} {d}\n");
    }
    s
}

/// `init` names a level from the level, not from an exporter's default file name; proposes
/// cells from the level's scale; stands probe A at eye height; and lights a closed level
/// with no lights from inside, where the light reaches its cells.
#[test]
fn init_names_sizes_and_lights_a_level_from_the_level() {
    let d = tmp_dir("init-level");
    let mut names = Vec::new();
    for level in ["alpha_room", "beta_room"] {
        std::fs::create_dir_all(d.join(level)).unwrap();
        let mesh = d.join(level).join("scene.obj");
        std::fs::write(&mesh, closed_room_obj(2.0, 2.0)).unwrap();
        let o = warpfit(&["init", "--mesh", &mesh.to_string_lossy()]);
        assert!(o.status.success(), "{}", text(&o));
        let scene_text = String::from_utf8(o.stdout).unwrap();
        let scene_path = d.join(format!("{level}.toml"));
        std::fs::write(&scene_path, scene_text.replace("\"scene.obj\"", &format!("\"{level}/scene.obj\""))).unwrap();
        let scene = Scene::load(&scene_path).unwrap();
        names.push(scene.name.clone());
        // a 2 m room: cells of 0.5, so 4 across (not 2 of the old default 1.0)
        assert!(scene.config.grid.counts.iter().all(|&c| c >= 4), "{:?}\n{scene_text}", scene.config.grid.counts);
        // probe A at eye height, or half-way up a room lower than twice that
        let y = scene.config.probe.position[1];
        assert!((y - 1.0).abs() < 0.05, "probe A at y = {y}\n{scene_text}");
        // closed and unlit: a light inside, and `check` finds light in the cells
        assert!(scene_text.contains("[[sphere_lights]]"), "{scene_text}");
        let o = warpfit(&["check", "--scene", &scene_path.to_string_lossy()]);
        assert!(o.status.success(), "{}", text(&o));
        assert!(!text(&o).contains("light reaches the grid"), "{}", text(&o));
        // without that lamp the sky and sun outside light nothing inside: `check` says so
        let lamp = scene_text.find("[[sphere_lights]]").unwrap();
        let end = lamp + scene_text[lamp..].find("\n\n").unwrap();
        let dark = d.join(format!("{level}-dark.toml"));
        std::fs::write(
            &dark,
            format!("{}{}", &scene_text[..lamp], &scene_text[end..])
                .replace("\"scene.obj\"", &format!("\"{level}/scene.obj\"")),
        )
        .unwrap();
        let o = warpfit(&["check", "--scene", &dark.to_string_lossy()]);
        assert!(text(&o).contains("no light reaches the grid's cells"), "{}", text(&o));
        // and cells of 2 in a 2 m room are called coarse
        let coarse = d.join(format!("{level}-coarse.toml"));
        let counts = format!("counts = {:?}", scene.config.grid.counts);
        std::fs::write(&coarse, std::fs::read_to_string(&scene_path).unwrap().replace(&counts, "counts = [1, 1, 1]"))
            .unwrap();
        let o = warpfit(&["check", "--scene", &coarse.to_string_lossy()]);
        assert!(text(&o).contains("coarse for this level's rooms"), "{}", text(&o));
    }
    assert_eq!(names, ["alpha_room", "beta_room"], "each level its own name, so its own fits/ folder");
}

/// A glTF whose lamp is a node without a KHR light and a material without emission (as
/// Blender exports one with punctual lights off): `init` names both in warnings.
#[test]
fn init_names_lamps_that_carry_no_light() {
    let d = tmp_dir("init-lamps");
    let gltf = quad_gltf(
        r#""materials":[{"name":"Lamp shade","pbrMetallicRoughness":{"baseColorFactor":[1,1,1,1]}}],"#,
        r#""nodes":[{"mesh":0},{"mesh":0,"translation":[0,2,0]},{"name":"Light","translation":[0,1,0]}],"scenes":[{"name":"Scene","nodes":[0,1,2]}],"#,
    );
    std::fs::create_dir_all(d.join("cellar")).unwrap();
    let mesh = d.join("cellar").join("scene.gltf");
    std::fs::write(&mesh, gltf).unwrap();
    let o = warpfit(&["init", "--mesh", &mesh.to_string_lossy(), "--cell-size", "0.5"]);
    let all = text(&o);
    assert!(o.status.success(), "{all}");
    assert!(all.contains("node \"Light\"") && all.contains("KHR_lights_punctual"), "{all}");
    assert!(all.contains("material \"Lamp shade\"") && all.contains("emits nothing"), "{all}");
    assert!(String::from_utf8_lossy(&o.stdout).contains("name = \"cellar\""), "{all}");
}
