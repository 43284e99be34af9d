//! The reference shader (`shaders/warpfit.wgsl`) is valid WGSL, its buffers are laid out as
//! the export writes them, and the shipped HLSL and GLSL are naga's translations of it as it
//! stands (`WARPFIT_BLESS=1 cargo test --release --test shader` rewrites them).

mod common;

use naga::back::{glsl, hlsl};
use naga::valid::{Capabilities, ValidationFlags, Validator};
use warpfit::export::shader::{CELL_BYTES, PARAMS_BYTES, SURFACE_PARAMS_BYTES};

const ENTRY_POINTS: [&str; 6] = [
    "specular_queries",
    "irradiance_queries",
    "warp1_queries",
    "box_queries",
    "surface_queries",
    "surface_warped_queries",
];

/// The vertex and pixel shader a level is drawn with: (entry point, stage, file suffix and
/// glslang's stage name).
const DRAW_STAGES: [(&str, naga::ShaderStage, &str); 2] =
    [("surface_vertex", naga::ShaderStage::Vertex, "vert"), ("surface_fragment", naga::ShaderStage::Fragment, "frag")];

fn module() -> (naga::Module, naga::valid::ModuleInfo) {
    let path = common::repo().join("shaders/warpfit.wgsl");
    let src = std::fs::read_to_string(&path).unwrap();
    let module = naga::front::wgsl::parse_str(&src).unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
    let info = Validator::new(ValidationFlags::all(), Capabilities::empty())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
    (module, info)
}

/// naga's translations: (file name under shaders/, text).
fn translations() -> Vec<(String, String)> {
    // the specialisation constants at their defaults (255: read from `params` at run time)
    let (module, info) = module();
    let (module, info) = naga::back::pipeline_constants::process_overrides(&module, &info, None, &Default::default())
        .expect("the overrides have defaults");
    let (module, info) = (module.into_owned(), info.into_owned());
    let mut out = Vec::new();
    let mut text = String::new();
    let options = hlsl::Options { shader_model: hlsl::ShaderModel::V5_1, ..Default::default() };
    hlsl::Writer::new(&mut text, &options, &hlsl::PipelineOptions::default())
        .write(&module, &info, None)
        .expect("HLSL");
    out.push(("warpfit.hlsl".to_string(), text));
    let stages = ENTRY_POINTS.iter().map(|&ep| (ep, naga::ShaderStage::Compute, "comp")).chain(DRAW_STAGES);
    for (ep, shader_stage, suffix) in stages {
        let mut text = String::new();
        let options =
            glsl::Options { version: glsl::Version::Desktop(450), binding_map: gl_bindings(), ..Default::default() };
        let pipeline = glsl::PipelineOptions { shader_stage, entry_point: ep.into(), multiview: None };
        glsl::Writer::new(&mut text, &module, &info, &options, &pipeline, Default::default())
            .and_then(|mut w| w.write())
            .unwrap_or_else(|e| panic!("GLSL {ep}: {e}"));
        out.push((format!("warpfit.{ep}.{suffix}.glsl"), text));
    }
    out
}

/// OpenGL binding points (textures, uniform and storage buffers count separately): the
/// textures at units 0–6 (bindings 0–6), `params` at uniform binding 0, `cells`, `queries`
/// and `results` at storage bindings 0, 1 and 2; a surface atlas (group 2) at texture units
/// 7 (radiance) and 8 (inverse distance) and uniform binding 1; the drawing camera (group
/// 3) at uniform binding 2.
fn gl_bindings() -> glsl::BindingMap {
    let rb = |group, binding| naga::ResourceBinding { group, binding };
    let mut map: glsl::BindingMap = (0..7).map(|b| (rb(0, b), b as u8)).collect();
    map.extend([
        (rb(0, 7), 0),
        (rb(0, 8), 0),
        (rb(1, 0), 1),
        (rb(1, 1), 2),
        (rb(2, 0), 7),
        (rb(2, 1), 1),
        (rb(2, 2), 8),
        (rb(3, 0), 2),
    ]);
    map
}

#[test]
fn the_shipped_translations_are_nagas_of_the_wgsl() {
    let bless = std::env::var("WARPFIT_BLESS").is_ok_and(|v| v == "1");
    for (name, text) in translations() {
        let path = common::repo().join("shaders").join(&name);
        if bless {
            std::fs::write(&path, &text).unwrap();
        }
        let shipped = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            shipped == text,
            "shaders/{name} is not naga's translation of shaders/warpfit.wgsl; rerun with WARPFIT_BLESS=1"
        );
    }
    // the export ships exactly these files
    let shipped: Vec<&str> = warpfit::export::shader::SHADER_FILES.iter().map(|(n, _)| *n).collect();
    let mut expected = vec!["warpfit.wgsl".to_string()];
    expected.extend(translations().into_iter().map(|(n, _)| n));
    assert_eq!(shipped, expected);
}

#[test]
fn the_buffers_have_the_shaders_layout() {
    let (module, _) = module();
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let size = |name: &str| {
        let (h, _) = module.types.iter().find(|(_, t)| t.name.as_deref() == Some(name)).expect(name);
        layouter[h].size as usize
    };
    assert_eq!(size("Params"), PARAMS_BYTES);
    assert_eq!(size("Cell"), CELL_BYTES);
    assert_eq!(size("SurfaceParams"), SURFACE_PARAMS_BYTES);
    // and the export writes buffers of those sizes
    let grid = warpfit::runtime::FittedGrid::load(common::repo().join("fits/tiny")).unwrap();
    let dir = common::tmp_dir("shader-buffers");
    let s = warpfit::export::export(&grid, &dir).unwrap();
    assert_eq!(std::fs::metadata(dir.join(&s.shader.params)).unwrap().len() as usize, PARAMS_BYTES);
    let cells = grid.correctives().geometry.cell_count();
    assert_eq!(std::fs::metadata(dir.join(&s.shader.cells)).unwrap().len() as usize, cells * CELL_BYTES);
    for name in &s.shader.sources {
        assert!(dir.join(name).is_file(), "{name} exported");
    }
}

/// The shipped translations compile in Khronos' reference compiler (glslang): the GLSL as
/// OpenGL compute shaders, the HLSL through glslang's HLSL front end, each kernel as the
/// entry point. `.ci/run` installs it (Debian `glslang-tools`).
#[test]
fn the_shipped_translations_compile_in_glslang() {
    let tool = "glslangValidator";
    if std::process::Command::new(tool).arg("--version").output().is_err() {
        common::tool_missing("compiling the HLSL and GLSL translations", tool, "apt-get install glslang-tools");
        return;
    }
    let shaders = common::repo().join("shaders");
    let scratch = common::tmp_dir("glslang");
    let out = scratch.join("out.spv");
    let run = |args: &[&str], file: &str| {
        let o = std::process::Command::new(tool).args(args).arg(shaders.join(file)).output().unwrap();
        assert!(
            o.status.success(),
            "glslang rejects shaders/{file} ({args:?}):\n{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
    };
    let out = out.to_str().unwrap();
    for ep in ENTRY_POINTS {
        run(&["-G", "-S", "comp", "-o", out], &format!("warpfit.{ep}.comp.glsl"));
        run(&["-D", "-V", "-S", "comp", "-e", ep, "-o", out], "warpfit.hlsl");
    }
    for (ep, _, stage) in DRAW_STAGES {
        run(&["-G", "-S", stage, "-o", out], &format!("warpfit.{ep}.{stage}.glsl"));
        run(&["-D", "-V", "-S", stage, "-e", ep, "-o", out], "warpfit.hlsl");
    }
}

/// The shader blends a cell's map and rough map over the roughness band the CPU runtime
/// uses (`warp::corrective::ROUGH_MAP_FROM`, `ROUGH_MAP_TO`): its constants are those.
#[test]
fn the_shaders_rough_map_band_is_the_runtimes() {
    use warpfit::warp::corrective::{ROUGH_MAP_FROM, ROUGH_MAP_TO};
    let src = std::fs::read_to_string(common::repo().join("shaders/warpfit.wgsl")).unwrap();
    for (name, want) in [("ROUGH_MAP_FROM", ROUGH_MAP_FROM), ("ROUGH_MAP_TO", ROUGH_MAP_TO)] {
        let prefix = format!("const {name}: f32 = ");
        let line =
            src.lines().find(|l| l.starts_with(&prefix)).unwrap_or_else(|| panic!("warpfit.wgsl: no `{prefix}`"));
        let got: f32 = line[prefix.len()..].trim_end_matches(';').parse().unwrap();
        assert_eq!(got, want, "warpfit.wgsl: {name}");
    }
}
