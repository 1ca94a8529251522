//! MTL material libraries (Wavefront), and how their materials map onto rlpt's
//! five (`docs/SCENE_FORMAT.md`, "Meshes"):
//!
//! - `Ke` is the emission (any kind may emit; a material that reflects nothing
//!   and emits is `emissive`). `Ka` is ambient colour, not light: ignored (and
//!   noted where it differs from `Kd` and is not black).
//! - dielectric: `illum` 4, 6 or 7, or transparency (`d` < 1, `Tr` > 0 or a
//!   `Tf` below 1) with `Ni` given; `ior` = `Ni` (1.5 where `Ni` is absent or
//!   below 1), albedo = `Tf` (default white).
//! - specular or glossy: `illum` 3 or 5, or `Ks` brighter than `Kd` (largest
//!   component) with `Ns` >= 20; albedo = `Ks`, roughness = (2 / (Ns + 2))^(1/4)
//!   (GGX alpha = roughness^2 = sqrt(2 / (Ns + 2)), the Phong-exponent match of
//!   Walter et al. 2007); below roughness 0.05, or without `Ns`, a perfect mirror.
//! - diffuse otherwise: albedo = `Kd` (black where absent).
//!
//! Colours are clamped to [0, 1] (emission to [0, 1e12]); a layer that is not
//! rendered (`Kd` beside a mirror, `Ks` beside a diffuse material), textures,
//! and transparency without `Ni` are named in the file's note.

use std::path::Path;

use glam::Vec3;

use super::{vec_text, FileMaterial, Ignored, Location, MeshError, SPECULAR_BELOW_ROUGHNESS};
use crate::scene::{Material, MaterialKind, TextureRef};

/// `Ns` from which a material whose `Ks` outshines its `Kd` counts as glossy.
const GLOSSY_MIN_NS: f32 = 20.0;
/// The index of refraction of a dielectric without a usable `Ni`.
const DEFAULT_IOR: f32 = 1.5;
/// Largest emission component (the scene format's limit).
const MAX_EMISSION: f32 = 1e12;

/// One `newmtl` and the statements after it, as written.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct MtlMaterial {
    pub(super) name: String,
    pub(super) ka: Option<Vec3>,
    pub(super) kd: Option<Vec3>,
    pub(super) ks: Option<Vec3>,
    pub(super) ke: Option<Vec3>,
    pub(super) tf: Option<Vec3>,
    pub(super) ns: Option<f32>,
    pub(super) ni: Option<f32>,
    pub(super) d: Option<f32>,
    pub(super) tr: Option<f32>,
    pub(super) illum: Option<u32>,
    /// Texture statements (`map_Kd`, `bump`, ...), by keyword.
    pub(super) textures: Vec<String>,
    /// `map_Kd`: the image as written, its line, and the UV scale and offset
    /// of its `-s` and `-o` options ([su, sv, ou, ov]).
    pub(super) map_kd: Option<(String, usize, [f32; 4])>,
    /// The MTL file (its directory resolves `map_Kd`).
    pub(super) file: std::path::PathBuf,
    /// Statements rlpt does not read (`Pr`, `sharpness`, spectral colours, ...).
    pub(super) other: Vec<String>,
}

/// Statements that name a texture.
const TEXTURE_KEYWORDS: &[&str] = &[
    "map_Ka", "map_Kd", "map_Ks", "map_Ke", "map_Ns", "map_d", "map_Tr", "map_bump", "map_Bump", "bump", "disp",
    "decal", "refl", "norm", "map_Pr", "map_Pm", "map_Ps", "map_aat",
];

/// A texture statement's words after its keyword: the file name (the words
/// after the options, joined by spaces), the UV transform of `-s` and `-o`
/// ([su, sv, ou, ov]), and the other options as written (not read).
fn texture_statement(rest: &[&str]) -> (String, [f32; 4], Vec<String>) {
    let mut transform = [1.0, 1.0, 0.0, 0.0];
    let mut other = Vec::new();
    let mut k = 0;
    while k < rest.len() && rest[k].starts_with('-') && rest[k].len() > 1 {
        let option = rest[k];
        // Arguments: up to three numbers for -s, -o, -t; two for -mm; one otherwise.
        let most = match option {
            "-s" | "-o" | "-t" => 3,
            "-mm" => 2,
            _ => 1,
        };
        let mut args = Vec::new();
        k += 1;
        while k < rest.len() && args.len() < most && (most == 1 || rest[k].parse::<f32>().is_ok()) {
            args.push(rest[k]);
            k += 1;
        }
        let n =
            |i: usize, d: f32| args.get(i).and_then(|a| a.parse::<f32>().ok()).filter(|x| x.is_finite()).unwrap_or(d);
        match option {
            "-s" => (transform[0], transform[1]) = (n(0, 1.0), n(1, 1.0)),
            "-o" => (transform[2], transform[3]) = (n(0, 0.0), n(1, 0.0)),
            _ => other.push(format!("{option} {}", args.join(" ")).trim().to_string()),
        }
    }
    (rest[k.min(rest.len())..].join(" "), transform, other)
}

/// Parses an MTL file's text; errors name `path` and the line.
pub(super) fn parse(path: &Path, text: &str) -> Result<Vec<MtlMaterial>, MeshError> {
    let mut materials: Vec<MtlMaterial> = Vec::new();
    for (line, content, keyword, rest) in super::keyword_lines(text) {
        let malformed = |message: String| MeshError::Malformed {
            path: path.to_path_buf(),
            location: Location::Line(line),
            message,
        };
        if keyword == "newmtl" {
            let name = content.trim_start()["newmtl".len()..].trim();
            if name.is_empty() {
                return Err(malformed("`newmtl` without a name; expected `newmtl NAME`".to_string()));
            }
            materials.push(MtlMaterial { name: name.to_string(), file: path.to_path_buf(), ..Default::default() });
            continue;
        }
        let Some(m) = materials.last_mut() else {
            return Err(malformed(format!("`{keyword}` before any `newmtl`; expected `newmtl NAME` first")));
        };
        let scalar = |what: &str| -> Result<f32, MeshError> {
            match rest.as_slice() {
                [x] => parse_number(path, line, x, what),
                _ => Err(malformed(format!("expected `{keyword}` and one number, found {} values", rest.len()))),
            }
        };
        match keyword {
            "Ka" | "Kd" | "Ks" | "Ke" | "Tf" => {
                if matches!(rest.first(), Some(&"spectral") | Some(&"xyz")) {
                    m.other.push(format!("{keyword} {}", rest[0]));
                    continue;
                }
                let colour = parse_colour(path, line, keyword, &rest)?;
                let slot = match keyword {
                    "Ka" => &mut m.ka,
                    "Kd" => &mut m.kd,
                    "Ks" => &mut m.ks,
                    "Ke" => &mut m.ke,
                    _ => &mut m.tf,
                };
                *slot = Some(colour);
            }
            "Ns" => m.ns = Some(non_negative(path, line, "Ns", scalar("the specular exponent Ns")?)?),
            "Ni" => m.ni = Some(scalar("the index of refraction Ni")?),
            "d" => {
                // `d -halo 0.5`: the halo form keeps its factor last.
                let x = match rest.as_slice() {
                    ["-halo", x] => parse_number(path, line, x, "the dissolve d")?,
                    _ => scalar("the dissolve d")?,
                };
                m.d = Some(x);
            }
            "Tr" => m.tr = Some(scalar("the transparency Tr")?),
            "illum" => {
                let value = match rest.as_slice() {
                    [x] => x.parse::<u32>().ok().filter(|&n| n <= 10),
                    _ => None,
                };
                match value {
                    Some(n) => m.illum = Some(n),
                    None => {
                        return Err(malformed(format!(
                            "expected `illum` and an illumination model from 0 to 10, found `{}`",
                            rest.join(" ")
                        )))
                    }
                }
            }
            "map_Kd" => {
                let (file, transform, options) = texture_statement(&rest);
                if file.is_empty() {
                    return Err(malformed("`map_Kd` without a file name; expected `map_Kd [options] FILE`".into()));
                }
                if !options.is_empty() {
                    m.other.push(format!("map_Kd options {}", options.join(" ")));
                }
                m.map_kd = Some((file, line, transform));
            }
            k if TEXTURE_KEYWORDS.contains(&k) => {
                if !m.textures.iter().any(|t| t == k) {
                    m.textures.push(k.to_string());
                }
            }
            other => {
                if !m.other.iter().any(|t| t == other) {
                    m.other.push(other.to_string());
                }
            }
        }
    }
    Ok(materials)
}

fn parse_number(path: &Path, line: usize, word: &str, what: &str) -> Result<f32, MeshError> {
    super::line_f32(path, line, word, "", what)
}

fn non_negative(path: &Path, line: usize, what: &str, x: f32) -> Result<f32, MeshError> {
    if x < 0.0 {
        return Err(MeshError::Malformed {
            path: path.to_path_buf(),
            location: Location::Line(line),
            message: format!("`{what}` must be >= 0, found {x}"),
        });
    }
    Ok(x)
}

/// `K r g b`, or `K r` for a grey; components >= 0.
fn parse_colour(path: &Path, line: usize, keyword: &str, words: &[&str]) -> Result<Vec3, MeshError> {
    let what = |c: usize| format!("component {} of `{keyword}`", c + 1);
    let v = match words {
        [r] => Vec3::splat(parse_number(path, line, r, &what(0))?),
        [r, g, b] => Vec3::new(
            parse_number(path, line, r, &what(0))?,
            parse_number(path, line, g, &what(1))?,
            parse_number(path, line, b, &what(2))?,
        ),
        _ => {
            return Err(MeshError::Malformed {
                path: path.to_path_buf(),
                location: Location::Line(line),
                message: format!(
                    "expected `{keyword} r g b` (or `{keyword} r` for a grey), found {} values",
                    words.len()
                ),
            })
        }
    };
    if v.min_element() < 0.0 {
        return Err(MeshError::Malformed {
            path: path.to_path_buf(),
            location: Location::Line(line),
            message: format!("`{keyword}` components must be >= 0, found {}", vec_text(v)),
        });
    }
    Ok(v)
}

/// GGX roughness of a Phong exponent: alpha = sqrt(2 / (Ns + 2)), roughness = sqrt(alpha).
pub(crate) fn roughness_from_ns(ns: f32) -> f32 {
    (2.0 / (ns.max(0.0) + 2.0)).powf(0.25)
}

/// Maps one MTL material onto rlpt's (the rules of this module's doc);
/// what it drops goes into `ignored`.
pub(super) fn map(m: &MtlMaterial, ignored: &mut Ignored) -> FileMaterial {
    let mut textures = m.textures.clone();
    let who = format!("`{}`", m.name);
    let mut clamped = false;
    let mut clamp = |v: Vec3, max: f32| {
        let c = v.clamp(Vec3::ZERO, Vec3::splat(max));
        clamped |= c != v;
        c
    };
    let kd = clamp(m.kd.unwrap_or(Vec3::ZERO), 1.0);
    let ks = clamp(m.ks.unwrap_or(Vec3::ZERO), 1.0);
    let emission = clamp(m.ke.unwrap_or(Vec3::ZERO), MAX_EMISSION);
    let illum = m.illum.unwrap_or(2);
    let transparent =
        m.d.is_some_and(|d| d < 1.0) || m.tr.is_some_and(|t| t > 0.0) || m.tf.is_some_and(|t| t.min_element() < 1.0);

    let mut material = Material { emission, ..Material::plain(m.name.clone(), MaterialKind::Diffuse, kd) };
    let mut mapping;
    if matches!(illum, 4 | 6 | 7) || (transparent && m.ni.is_some()) {
        material.kind = MaterialKind::Dielectric;
        material.albedo = clamp(m.tf.unwrap_or(Vec3::ONE), 1.0);
        let why = if matches!(illum, 4 | 6 | 7) { format!("illum {illum}") } else { "transparent with Ni".to_string() };
        mapping = format!("dielectric ({why}), albedo {}", vec_text(material.albedo));
        mapping += if m.tf.is_some() { " from Tf" } else { " (no Tf)" };
        match m.ni {
            Some(ni) if ni >= 1.0 => {
                material.ior = ni;
                mapping += &format!(", ior {ni} from Ni");
            }
            Some(ni) => {
                material.ior = DEFAULT_IOR;
                mapping += &format!(", ior {DEFAULT_IOR} (Ni {ni} is below 1)");
            }
            None => {
                material.ior = DEFAULT_IOR;
                mapping += &format!(", ior {DEFAULT_IOR} (no Ni)");
            }
        }
        if kd.max_element() > 0.0 {
            ignored.add("the diffuse layer (Kd) of transparent materials", who.clone());
        }
    } else if matches!(illum, 3 | 5)
        || (ks.max_element() > kd.max_element() && m.ns.is_some_and(|ns| ns >= GLOSSY_MIN_NS))
    {
        material.albedo = ks;
        let why = if matches!(illum, 3 | 5) {
            format!("illum {illum}")
        } else {
            format!("Ks outshines Kd, Ns >= {GLOSSY_MIN_NS}")
        };
        let roughness = m.ns.map(roughness_from_ns);
        match roughness {
            Some(r) if r >= SPECULAR_BELOW_ROUGHNESS => {
                material.kind = MaterialKind::Glossy;
                material.roughness = r;
                mapping = format!(
                    "glossy ({why}), albedo {} from Ks, roughness {r} = (2 / (Ns + 2))^(1/4) of Ns {}",
                    vec_text(ks),
                    m.ns.unwrap_or(0.0)
                );
            }
            _ => {
                material.kind = MaterialKind::Specular;
                let detail = match m.ns {
                    Some(ns) => format!("roughness of Ns {ns} below {SPECULAR_BELOW_ROUGHNESS}"),
                    None => "no Ns".to_string(),
                };
                mapping = format!("specular mirror ({why}, {detail}), albedo {} from Ks", vec_text(ks));
            }
        }
        if kd.max_element() > 0.0 {
            ignored.add("the diffuse layer (Kd) of reflective materials", who.clone());
        }
    } else {
        mapping = format!("diffuse, albedo {} from Kd", vec_text(kd));
        if m.kd.is_none() {
            mapping += " (no Kd: black)";
        }
        // map_Kd takes Kd's place (as Blender reads it); a missing image leaves Kd, noted.
        if let Some((file, line, transform)) = &m.map_kd {
            let dir = m.file.parent().unwrap_or(Path::new(""));
            let usage = crate::scene::TextureUse::Colour;
            let origin = m.file.display().to_string();
            let r =
                TextureRef { transform: *transform, ..TextureRef::new(file, dir, &origin, Some((*line, 1)), usage) };
            if r.path.is_file() {
                material.albedo = Vec3::ONE;
                mapping = format!("diffuse, albedo texture {} from map_Kd (in place of Kd)", r.path.display());
                material.albedo_texture = Some(r);
            } else {
                let place = format!("{} of {who} (line {line}: {} does not exist)", "map_Kd", r.shown());
                ignored.add("textures", place);
            }
        }
        if ks.max_element() > 0.0 {
            ignored.add("the specular layer (Ks) of diffuse materials", who.clone());
        }
        if transparent {
            ignored.add("transparency (d, Tr, Tf) without Ni", who.clone());
        }
    }
    if emission.max_element() > 0.0 {
        mapping += &format!(", emission {} from Ke", vec_text(emission));
        if material.kind == MaterialKind::Diffuse && kd == Vec3::ZERO && ks == Vec3::ZERO {
            material.kind = MaterialKind::Emissive;
            material.albedo = Vec3::ZERO;
            mapping = format!("emissive (reflects nothing), emission {} from Ke", vec_text(emission));
        }
    }
    if clamped {
        mapping += ", colours clamped to [0, 1]";
        ignored.add("colours beyond [0, 1] (clamped)", who.clone());
    }
    if let Some(ka) = m.ka {
        if ka.max_element() > 0.0 && Some(ka) != m.kd {
            ignored.add("ambient colour Ka (rlpt reads emission from Ke)", who.clone());
        }
    }
    if m.map_kd.is_some() && material.kind != MaterialKind::Diffuse {
        textures.insert(0, "map_Kd".to_string());
    }
    if !textures.is_empty() {
        ignored.add("textures", format!("{} of {who}", textures.join(", ")));
    }
    for other in &m.other {
        ignored.add("MTL statements rlpt does not read", format!("{other} of {who}"));
    }
    FileMaterial { name: m.name.clone(), material, mapping: format!("MTL {who}: {mapping}") }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(text: &str) -> (FileMaterial, Option<String>) {
        let materials = parse(Path::new("t.mtl"), text).unwrap();
        assert_eq!(materials.len(), 1);
        let mut ignored = Ignored::default();
        let m = map(&materials[0], &mut ignored);
        (m, ignored.note())
    }

    #[test]
    fn kd_is_diffuse_and_ke_emits() {
        let (m, note) =
            one("newmtl light\n  Ka 0.78 0.78 0.78 # White\n  Kd 0.78 0.78 0.78\n  Ks 0 0 0\n  Ke 17 12 4\n");
        assert_eq!(m.material.kind, MaterialKind::Diffuse);
        assert_eq!(m.material.albedo, Vec3::splat(0.78));
        assert_eq!(m.material.emission, Vec3::new(17.0, 12.0, 4.0));
        assert_eq!(note, None);
        assert!(m.mapping.contains("emission [17, 12, 4] from Ke"), "{}", m.mapping);
    }

    #[test]
    fn ka_is_not_emission_and_is_noted() {
        let (m, note) = one("newmtl light\nKa 20 20 20\nKd 1 1 1\nKs 0 0 0\n");
        assert_eq!(m.material.emission, Vec3::ZERO);
        assert!(note.unwrap().contains("ambient colour Ka (rlpt reads emission from Ke) (`light`)"));
    }

    #[test]
    fn ke_alone_is_emissive() {
        let (m, _) = one("newmtl lamp\nKe 5 5 5\n");
        assert_eq!(m.material.kind, MaterialKind::Emissive);
        assert_eq!(m.material.emission, Vec3::splat(5.0));
    }

    #[test]
    fn glass_from_illum_or_transparency_with_ni() {
        let (m, _) = one("newmtl glass\nillum 7\nNi 1.33\nKd 0 0 0\n");
        assert_eq!((m.material.kind, m.material.ior, m.material.albedo), (MaterialKind::Dielectric, 1.33, Vec3::ONE));
        let (m, _) = one("newmtl glass\nd 0.2\nNi 1.6\nTf 0.9 1 1\n");
        assert_eq!((m.material.kind, m.material.ior), (MaterialKind::Dielectric, 1.6));
        assert_eq!(m.material.albedo, Vec3::new(0.9, 1.0, 1.0));
        let (m, note) = one("newmtl glass\nillum 4\n");
        assert_eq!(m.material.ior, DEFAULT_IOR);
        assert!(m.mapping.contains("(no Ni)"));
        assert_eq!(note, None);
        // Transparency without Ni is alpha: dropped, and said so.
        let (m, note) = one("newmtl veil\nKd 0.5 0.5 0.5\nd 0.5\n");
        assert_eq!(m.material.kind, MaterialKind::Diffuse);
        assert!(note.unwrap().contains("transparency (d, Tr, Tf) without Ni (`veil`)"));
    }

    #[test]
    fn reflective_from_illum_or_ks_with_ns() {
        let (m, note) = one("newmtl metal\nKd 0.1 0.1 0.1\nKs 0.9 0.8 0.7\nNs 100\n");
        assert_eq!(m.material.kind, MaterialKind::Glossy);
        assert_eq!(m.material.albedo, Vec3::new(0.9, 0.8, 0.7));
        assert!((m.material.roughness - (2.0f32 / 102.0).powf(0.25)).abs() < 1e-6);
        assert!(note.unwrap().contains("the diffuse layer (Kd) of reflective materials (`metal`)"));
        let (m, _) = one("newmtl mirror\nillum 3\nKs 1 1 1\n");
        assert_eq!(m.material.kind, MaterialKind::Specular);
        // Ns so high that the roughness falls below 0.05: a mirror.
        let (m, _) = one("newmtl mirror\nillum 5\nKs 1 1 1\nNs 4000000\n");
        assert_eq!(m.material.kind, MaterialKind::Specular);
        // Ks brighter but a low exponent: diffuse, the Ks layer noted.
        let (m, note) = one("newmtl plastic\nKd 0.2 0.2 0.2\nKs 0.5 0.5 0.5\nNs 10\n");
        assert_eq!(m.material.kind, MaterialKind::Diffuse);
        assert!(note.unwrap().contains("the specular layer (Ks) of diffuse materials (`plastic`)"));
    }

    #[test]
    fn roughness_formula() {
        assert_eq!(roughness_from_ns(0.0), 1.0);
        assert!((roughness_from_ns(1000.0) - 0.2114).abs() < 1e-3);
    }

    #[test]
    fn textures_and_unknown_statements_are_noted_and_colours_clamped() {
        let (m, note) = one("newmtl wood\nKd 1.5 0.5 0.5\nmap_Kd wood.png\nbump wood_n.png\nPr 0.5\n");
        assert_eq!(m.material.albedo, Vec3::new(1.0, 0.5, 0.5));
        let note = note.unwrap();
        // The missing map_Kd image leaves Kd, said so with its line; bump maps are not read.
        assert!(m.material.albedo_texture.is_none());
        assert!(
            note.contains("textures (map_Kd of `wood` (line 3: \"wood.png\" does not exist), bump of `wood`)"),
            "{note}"
        );
        assert!(note.contains("MTL statements rlpt does not read (Pr of `wood`)"), "{note}");
        assert!(note.contains("colours beyond [0, 1] (clamped) (`wood`)"), "{note}");
    }

    #[test]
    fn refusals_name_the_line() {
        let refuse = |text: &str| parse(Path::new("t.mtl"), text).unwrap_err().to_string();
        assert_eq!(refuse("newmtl a\nKd 1 1\n"), "t.mtl:2: expected `Kd r g b` (or `Kd r` for a grey), found 2 values");
        assert_eq!(refuse("newmtl a\n\nKd 1 x 1\n"), "t.mtl:3: expected a number for component 2 of `Kd`, found `x`");
        assert_eq!(
            refuse("newmtl a\nKe 1 nan 1\n"),
            "t.mtl:2: component 2 of `Ke` is `nan` (NaN); expected a finite number"
        );
        assert_eq!(refuse("Kd 1 1 1\n"), "t.mtl:1: `Kd` before any `newmtl`; expected `newmtl NAME` first");
        assert_eq!(refuse("newmtl a\nKd -1 0 0\n"), "t.mtl:2: `Kd` components must be >= 0, found [-1, 0, 0]");
        assert_eq!(
            refuse("newmtl a\nillum x\n"),
            "t.mtl:2: expected `illum` and an illumination model from 0 to 10, found `x`"
        );
    }
}
