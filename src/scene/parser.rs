//! Recursive-descent parser for the scene format (docs/SPEC.md §2).
//!
//! One function per grammar rule, except that the one rule that nests (Group/Transform
//! objects) keeps its open blocks on an explicit stack instead of recursing, so no input
//! can exhaust the call stack. Every error is located at the token that caused it and
//! says what was expected and what was found. The parser reads the token stream once; the
//! only checks deferred to the end are those that need a block written later in the file
//! (material indices used before the `Materials` block).

use super::error::{SceneError, SceneWarning};
use super::lexer::{describe, parse_count, parse_decimal, read_source, Lexer, Token};
use super::model::{
    Background, Camera, DirectionalLight, Light, Location, Material, Mesh, Object, PointLight, Projection, Scene,
    Shape, Texture, TextureKind,
};
use super::obj::{load_obj, parse_obj};
use glam::{DMat3, DMat4, DVec3, DVec4};
use std::collections::HashMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The deepest nesting of `Group`/`Transform` blocks accepted (the top-level `Group` is
/// level 1). Deeper nesting is an error at the keyword that exceeds it. The parser itself
/// needs no such limit; the code that later walks the tree recursively (drop, clone, the
/// renderers) does, and 1000 levels fit in a 2 MiB thread stack.
pub const MAX_NESTING: usize = 1000;

/// Reads the scene file at `path` and parses it with [`parse_scene`].
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    let text = read_source(path)?;
    parse_scene(&text, path)
}

/// Parses scene text (docs/SPEC.md §2). `path` is the file the text came from: it names the
/// file in error messages and is the folder `obj_file` paths are resolved against (before
/// the working directory). OBJ meshes are loaded while parsing; a mesh used twice is loaded
/// once and shared.
///
/// Transforms compose as `M = T1 · T2 · … · Tn` (the first listed is applied last), except
/// `Matrix { … }`, which pre-multiplies (`M = Matrix · M_so_far`) as the course's reference
/// parser does: `Translate 1 0 0 Matrix {…}` applies the translation first, then the matrix.
pub fn parse_scene(text: &str, path: &Path) -> Result<Scene, SceneError> {
    parse_scene_with(text, path, ObjFiles::Disk)
}

/// As [`parse_scene`], reading the `obj_file`s from `files`: the same grammar, the same
/// path resolution and the same located errors, whether the meshes are on disk or held in
/// memory (a browser's dropped or fetched files, docs/SPEC.md §10).
pub fn parse_scene_with(text: &str, path: &Path, files: ObjFiles) -> Result<Scene, SceneError> {
    Parser::new(text, path, files).scene()
}

/// Where a scene's `obj_file`s are read from.
#[derive(Clone, Copy, Debug)]
pub enum ObjFiles<'a> {
    /// The file system (the command line).
    Disk,
    /// Texts by path, as [`parse_scene`] would resolve them on disk (the scene's folder
    /// joined with the name, then the name alone); a path not in the map does not exist.
    Memory(&'a HashMap<PathBuf, String>),
}

/// The names the scene's `obj_file`s give, in file order, as written (a page fetches them
/// before parsing; a name that is not a mesh path is left to the parser to report).
pub fn obj_file_names(text: &str) -> Vec<String> {
    let mut lexer = Lexer::new(text);
    let mut names = Vec::new();
    while let Some(token) = lexer.next_token() {
        if token.text == "obj_file" {
            names.extend(lexer.next_token().map(|name| name.text.to_string()));
        }
    }
    names
}

type Result<T, E = SceneError> = std::result::Result<T, E>;

const TOP_LEVEL_BLOCKS: &str = "one of OrthographicCamera, PerspectiveCamera, Lights, Background, Materials, Group";
const OBJECT_KEYWORDS: [&str; 6] = ["Group", "Sphere", "Plane", "Triangle", "TriangleMesh", "Transform"];
const GROUP_ITEMS: &str = "`}`, MaterialIndex or an object (Group, Sphere, Plane, Triangle, TriangleMesh, Transform)";
const TRANSFORM_ITEMS: &str = "a transformation (Scale, UniformScale, Translate, XRotate, YRotate, \
     ZRotate, Rotate, Matrix) or an object (Group, Sphere, Plane, Triangle, TriangleMesh, Transform)";
const TRANSFORMATIONS: [&str; 8] =
    ["Scale", "UniformScale", "Translate", "XRotate", "YRotate", "ZRotate", "Rotate", "Matrix"];
const MATERIAL_KINDS: &str = "`}`, Material, PhongMaterial, Checkerboard, Noise, Marble or Wood";

/// The most `octaves` a noise sum may have: octave k adds at most 2⁻ᵏ of the first one's
/// size, so beyond 64 it changes nothing an f64 can hold, and a huge count would only stall
/// the render.
pub const MAX_OCTAVES: u64 = 64;

/// The deepest chain of textures naming textures: each level may shade both of its
/// materials, so one hit can cost 2^depth Phong shadings. The course nests two deep.
pub const MAX_TEXTURE_NESTING: usize = 8;

const PHONG_FIELDS: [&str; 6] =
    ["diffuseColor", "specularColor", "exponent", "transparentColor", "reflectiveColor", "indexOfRefraction"];

/// The top-level blocks read so far (each may appear once).
#[derive(Default)]
struct TopLevel {
    camera: Option<Camera>,
    lights: Option<Vec<Light>>,
    background: Option<BackgroundBlock>,
    materials: Option<Vec<MaterialEntry>>,
    root: Option<Vec<Object>>,
    /// Block kind and keyword location, to report duplicates.
    seen: Vec<(&'static str, Location)>,
}

/// One entry of the `Materials` block: its Phong terms (a texture's stand-in, see
/// [`Scene::textures`]), its texture if it is one, and where its keyword was written.
type MaterialEntry = (Material, Option<Texture>, Location);

struct BackgroundBlock {
    background: Background,
    /// Whether the file set `ambientLight` (the no-lights warning mentions the override).
    ambient_given: bool,
}

/// How one `Transform` step combines with the matrix built so far.
enum Compose {
    /// `M = M · T` (Scale, Translate, rotations).
    After(DMat4),
    /// `M = T · M` (`Matrix`, the reference parser's quirk).
    Before(DMat4),
}

/// A `Group` or `Transform` whose closing brace has not been read yet.
enum OpenBlock<'a> {
    Group {
        keyword: Token<'a>,
        count: Count<'a>,
        children: Vec<Object>,
    },
    /// `child` is the object once read; only the `}` may follow it.
    Transform {
        keyword: Token<'a>,
        matrix: DMat4,
        child: Option<Box<Object>>,
    },
}

impl OpenBlock<'_> {
    /// Takes in a finished object as the block's next child.
    fn adopt(&mut self, object: Object) {
        match self {
            OpenBlock::Group { children, .. } => children.push(object),
            OpenBlock::Transform { child, .. } => *child = Some(Box::new(object)),
        }
    }
}

/// The start of an object: finished if it is a leaf, still open if it is a block.
enum Begun<'a> {
    Leaf(Object),
    Block(OpenBlock<'a>),
}

/// What the next item of an open block was.
enum Item<'a> {
    /// A `MaterialIndex` or a transformation step, already applied.
    Consumed,
    /// An object starts at this keyword.
    Object(Token<'a>),
    /// The closing brace: the block is finished as this object.
    Closed(Object),
}

/// The declared and actual number of items of a counted block (`numObjects` and friends).
struct Count<'a> {
    block: &'a str,
    field: &'static str,
    noun: &'static str,
    declared: u64,
    found: u64,
}

impl Count<'_> {
    /// Counts one more item; the error message if that is one more than declared.
    fn add(&mut self) -> Option<String> {
        self.found += 1;
        (self.found > self.declared).then(|| {
            format!(
                "{} declares {} {} but has at least {} {}",
                self.block, self.field, self.declared, self.found, self.noun
            )
        })
    }

    /// The error message if fewer items than declared were found.
    fn shortfall(&self) -> Option<String> {
        (self.found != self.declared).then(|| {
            format!("{} declares {} {} but has {} {}", self.block, self.field, self.declared, self.found, self.noun)
        })
    }
}

struct Parser<'a> {
    lexer: Lexer<'a>,
    path: &'a Path,
    files: ObjFiles<'a>,
    /// `numMaterials`, once the `Materials` block has been read.
    material_count: Option<usize>,
    /// The material of the last `MaterialIndex`: it applies to every following object in
    /// file order, whatever the hierarchy.
    current_material: Option<u32>,
    /// Material indices read before the `Materials` block, checked at the end.
    unchecked_material_refs: Vec<(u32, Location)>,
    /// Loaded meshes by canonical path, so a mesh used twice is shared.
    meshes: HashMap<PathBuf, Arc<Mesh>>,
    warnings: Vec<SceneWarning>,
}

impl<'a> Parser<'a> {
    fn new(text: &'a str, path: &'a Path, files: ObjFiles<'a>) -> Self {
        Parser {
            lexer: Lexer::new(text),
            path,
            files,
            material_count: None,
            current_material: None,
            unchecked_material_refs: Vec::new(),
            meshes: HashMap::new(),
            warnings: Vec::new(),
        }
    }

    // ---- tokens and errors ----

    fn error(&self, location: Location, message: impl Into<String>) -> SceneError {
        SceneError::at(self.path, location, message)
    }

    /// The next token; at the end of the file, an error saying what was `expected`.
    fn expect(&mut self, expected: &str) -> Result<Token<'a>> {
        self.lexer
            .next_token()
            .ok_or_else(|| self.error(self.lexer.location(), format!("unexpected end of file, expected {expected}")))
    }

    fn unexpected(&self, token: Token, expected: &str) -> SceneError {
        self.error(token.location, format!("expected {expected}, found {}", describe(token.text)))
    }

    /// "unknown KIND `word`, expected …" for a word; a brace gets the plain "expected …".
    fn unknown(&self, token: Token, kind: &str, expected: &str) -> SceneError {
        self.unknown_in(token, kind, "", expected)
    }

    /// Like [`Self::unknown`], naming the enclosing block: "unknown field `x` in Sphere, …".
    fn unknown_in(&self, token: Token, kind: &str, block: &str, expected: &str) -> SceneError {
        if token.text == "{" || token.text == "}" {
            return self.unexpected(token, expected);
        }
        let place = if block.is_empty() { String::new() } else { format!(" in {block}") };
        self.error(token.location, format!("unknown {kind} {}{place}, expected {expected}", describe(token.text)))
    }

    /// The `{` that must follow `keyword`.
    fn open(&mut self, keyword: Token) -> Result<()> {
        self.punctuation("{", &format!("`{{` after {}", keyword.text))
    }

    fn punctuation(&mut self, brace: &str, expected: &str) -> Result<()> {
        let token = self.expect(expected)?;
        if token.text == brace {
            Ok(())
        } else {
            Err(self.unexpected(token, expected))
        }
    }

    fn number(&mut self) -> Result<(f64, Location)> {
        let token = self.expect("a number")?;
        match parse_decimal(token.text) {
            Some(value) => Ok((value, token.location)),
            None => Err(self.error(token.location, format!("expected a number, found {}", describe(token.text)))),
        }
    }

    /// Three numbers, and the location of the first.
    fn vec3(&mut self) -> Result<(DVec3, Location)> {
        let (x, location) = self.number()?;
        let (y, _) = self.number()?;
        let (z, _) = self.number()?;
        Ok((DVec3::new(x, y, z), location))
    }

    fn nonzero_vec3(&mut self, what: &str) -> Result<DVec3> {
        let (v, location) = self.vec3()?;
        if v == DVec3::ZERO {
            return Err(self.error(location, format!("{what} must not be the zero vector")));
        }
        Ok(v)
    }

    fn positive(&mut self, what: &str) -> Result<f64> {
        let (value, location) = self.number()?;
        if value <= 0.0 {
            return Err(self.error(location, format!("{what} must be positive, found {}", show1(value))));
        }
        Ok(value)
    }

    /// A non-negative integer (counts and indices).
    fn count_value(&mut self) -> Result<(u64, Location)> {
        let token = self.expect("a non-negative integer")?;
        match parse_count(token.text) {
            Some(value) => Ok((value, token.location)),
            None => Err(self.unexpected(token, "a non-negative integer")),
        }
    }

    /// `FIELD N`, the first line of a counted block such as `Group { numObjects N … }`.
    fn count_field(&mut self, keyword: Token<'a>, field: &'static str, noun: &'static str) -> Result<Count<'a>> {
        let expected = format!("`{field}` after `{} {{`", keyword.text);
        let token = self.expect(&expected)?;
        if token.text != field {
            return Err(self.unexpected(token, &expected));
        }
        let (declared, _) = self.count_value()?;
        Ok(Count { block: keyword.text, field, noun, declared, found: 0 })
    }

    // ---- blocks of named fields ----

    /// `{ (FIELD value)* }` with each of `fields` at most once, in any order; `field` parses
    /// the value of the field whose name token it is given. Returns where the `}` is, to
    /// locate "missing field" errors.
    fn fields_block(
        &mut self,
        keyword: Token,
        fields: &[&'static str],
        mut field: impl FnMut(&mut Self, Token<'a>) -> Result<()>,
    ) -> Result<Location> {
        self.open(keyword)?;
        let expected = format!("`}}` or one of {}", fields.join(", "));
        let mut seen: Vec<&str> = Vec::new();
        loop {
            let token = self.expect(&expected)?;
            if token.text == "}" {
                return Ok(token.location);
            }
            if !fields.contains(&token.text) {
                return Err(self.unknown_in(token, "field", keyword.text, &expected));
            }
            if seen.contains(&token.text) {
                return Err(self.error(token.location, format!("duplicate field `{}` in {}", token.text, keyword.text)));
            }
            seen.push(token.text);
            field(self, token)?;
        }
    }

    fn required<T>(&self, value: Option<T>, keyword: Token, field: &str, close: Location) -> Result<T> {
        value.ok_or_else(|| self.error(close, format!("{} is missing `{field}`", keyword.text)))
    }

    // ---- top level ----

    fn scene(mut self) -> Result<Scene> {
        let mut blocks = TopLevel::default();
        while let Some(token) = self.lexer.next_token() {
            self.top_level_block(token, &mut blocks)?;
        }
        self.finish(blocks)
    }

    fn top_level_block(&mut self, token: Token<'a>, blocks: &mut TopLevel) -> Result<()> {
        match token.text {
            "OrthographicCamera" | "PerspectiveCamera" => {
                self.first_of_kind("camera", token, &mut blocks.seen)?;
                blocks.camera = Some(self.camera(token)?);
            }
            "Lights" => {
                self.first_of_kind("Lights", token, &mut blocks.seen)?;
                blocks.lights = Some(self.lights(token)?);
            }
            "Background" => {
                self.first_of_kind("Background", token, &mut blocks.seen)?;
                blocks.background = Some(self.background(token)?);
            }
            "Materials" => {
                self.first_of_kind("Materials", token, &mut blocks.seen)?;
                blocks.materials = Some(self.materials(token)?);
            }
            "Group" => {
                self.first_of_kind("Group", token, &mut blocks.seen)?;
                if let Shape::Group(children) = self.object(token)?.shape {
                    blocks.root = Some(children);
                }
            }
            _ => return Err(self.unknown(token, "block", TOP_LEVEL_BLOCKS)),
        }
        Ok(())
    }

    fn first_of_kind(&self, kind: &'static str, token: Token, seen: &mut Vec<(&'static str, Location)>) -> Result<()> {
        if let Some((_, first)) = seen.iter().find(|(k, _)| *k == kind) {
            return Err(self.error(
                token.location,
                format!("duplicate {kind} block (the first one is at {}:{})", first.line, first.col),
            ));
        }
        seen.push((kind, token.location));
        Ok(())
    }

    fn finish(mut self, blocks: TopLevel) -> Result<Scene> {
        let camera = blocks.camera.ok_or_else(|| {
            SceneError::in_file(self.path, "no camera: expected an OrthographicCamera or PerspectiveCamera block")
        })?;
        let entries = blocks.materials.unwrap_or_default();
        let materials: Vec<Material> = entries.iter().map(|entry| entry.0).collect();
        let material_locations = entries.iter().map(|entry| entry.2).collect();
        let mut textures: Vec<Option<Texture>> = entries.iter().map(|entry| entry.1).collect();
        if textures.iter().all(Option::is_none) {
            textures.clear();
        }
        self.check_material_refs(materials.len())?;
        let lights = blocks.lights.unwrap_or_default();
        let mut background =
            blocks.background.unwrap_or(BackgroundBlock { background: Background::default(), ambient_given: false });
        if lights.is_empty() {
            // At the empty Lights block if there is one; a file without one has no place to point at.
            let lights_block = blocks.seen.iter().find(|(kind, _)| *kind == "Lights").map(|&(_, at)| at);
            self.warnings.push(SceneWarning::new(self.path, lights_block, no_lights_warning(&background)));
            background.background.ambient = DVec3::ONE;
        }
        Ok(Scene {
            path: self.path.to_path_buf(),
            camera,
            lights,
            background: background.background,
            materials,
            material_locations,
            textures,
            root: blocks.root.unwrap_or_default(),
            warnings: self.warnings,
        })
    }

    /// Checks the material indices that were read before the `Materials` block.
    fn check_material_refs(&self, material_count: usize) -> Result<()> {
        match self.unchecked_material_refs.iter().find(|(index, _)| *index as usize >= material_count) {
            Some(&(index, location)) => Err(self.material_out_of_range(index.into(), material_count, location)),
            None => Ok(()),
        }
    }

    fn material_out_of_range(&self, index: u64, material_count: usize, location: Location) -> SceneError {
        self.error(location, format!("MaterialIndex {index} out of range: numMaterials is {material_count}"))
    }

    // ---- camera, lights, background, materials ----

    fn camera(&mut self, keyword: Token<'a>) -> Result<Camera> {
        let perspective = keyword.text == "PerspectiveCamera";
        let extent_field = if perspective { "angle" } else { "size" };
        let (mut center, mut direction, mut up, mut extent) = (None, None, None, None);
        let close = self.fields_block(keyword, &["center", "direction", "up", extent_field], |p, field| {
            match field.text {
                "center" => center = Some(p.vec3()?.0),
                "direction" => direction = Some(p.nonzero_vec3("direction")?),
                "up" => up = Some((p.nonzero_vec3("up")?, field.location)),
                _ if perspective => extent = Some(p.field_of_view()?),
                _ => extent = Some(p.positive("size")?),
            }
            Ok(())
        })?;
        let extent = self.required(extent, keyword, extent_field, close)?;
        let (up, up_location) = self.required(up, keyword, "up", close)?;
        let projection = if perspective {
            Projection::Perspective { angle: extent }
        } else {
            Projection::Orthographic { size: extent }
        };
        let center = self.required(center, keyword, "center", close)?;
        let direction = self.required(direction, keyword, "direction", close)?;
        Camera::new(projection, center, direction, up, keyword.location)
            .ok_or_else(|| self.error(up_location, degenerate_camera_message(direction, up)))
    }

    /// A perspective camera's `angle`: degrees in the file, radians in the model.
    fn field_of_view(&mut self) -> Result<f64> {
        let (degrees, location) = self.number()?;
        if !(degrees > 0.0 && degrees < 180.0) {
            return Err(
                self.error(location, format!("angle must be between 0 and 180 degrees, found {}", show1(degrees)))
            );
        }
        Ok(degrees.to_radians())
    }

    fn lights(&mut self, keyword: Token<'a>) -> Result<Vec<Light>> {
        const ITEMS: &str = "`}`, DirectionalLight or PointLight";
        self.open(keyword)?;
        let mut count = self.count_field(keyword, "numLights", "lights")?;
        let mut lights = Vec::new();
        loop {
            let token = self.expect(ITEMS)?;
            match token.text {
                "}" => {
                    self.check_shortfall(&count, token)?;
                    return Ok(lights);
                }
                "DirectionalLight" => {
                    self.check_extra(&mut count, token)?;
                    lights.push(Light::Directional(self.directional_light(token)?));
                }
                "PointLight" => {
                    self.check_extra(&mut count, token)?;
                    lights.push(Light::Point(self.point_light(token)?));
                }
                _ => return Err(self.unknown(token, "light", ITEMS)),
            }
        }
    }

    fn check_extra(&self, count: &mut Count, token: Token) -> Result<()> {
        match count.add() {
            Some(message) => Err(self.error(token.location, message)),
            None => Ok(()),
        }
    }

    fn check_shortfall(&self, count: &Count, close: Token) -> Result<()> {
        match count.shortfall() {
            Some(message) => Err(self.error(close.location, message)),
            None => Ok(()),
        }
    }

    fn directional_light(&mut self, keyword: Token<'a>) -> Result<DirectionalLight> {
        let (mut direction, mut color) = (None, None);
        let close = self.fields_block(keyword, &["direction", "color"], |p, field| {
            match field.text {
                "direction" => direction = Some(p.nonzero_vec3("light direction")?),
                _ => color = Some(p.vec3()?.0),
            }
            Ok(())
        })?;
        Ok(DirectionalLight {
            direction: self.required(direction, keyword, "direction", close)?,
            color: self.required(color, keyword, "color", close)?,
        })
    }

    /// `PointLight { position V3 color V3 attenuation a0 a1 a2 }`, attenuation optional
    /// (default 1 0 0). The coefficients must be ≥ 0 and not all 0, so that the divisor
    /// `a0 + a1·d + a2·d²` is positive wherever d > 0 (GRAMMAR.md A4).
    fn point_light(&mut self, keyword: Token<'a>) -> Result<PointLight> {
        let (mut position, mut color, mut attenuation) = (None, None, DVec3::X);
        let close = self.fields_block(keyword, &["position", "color", "attenuation"], |p, field| {
            match field.text {
                "position" => position = Some(p.vec3()?.0),
                "color" => color = Some(p.vec3()?.0),
                _ => {
                    let (a, at) = p.vec3()?;
                    if a.min_element() < 0.0 || a == DVec3::ZERO {
                        return Err(p.error(
                            at,
                            format!(
                                "attenuation must be three coefficients ≥ 0, not all 0, found {} {} {}",
                                show1(a.x),
                                show1(a.y),
                                show1(a.z)
                            ),
                        ));
                    }
                    attenuation = a;
                }
            }
            Ok(())
        })?;
        Ok(PointLight {
            position: self.required(position, keyword, "position", close)?,
            color: self.required(color, keyword, "color", close)?,
            attenuation,
            location: keyword.location,
        })
    }

    fn background(&mut self, keyword: Token<'a>) -> Result<BackgroundBlock> {
        let mut background = Background::default();
        let mut ambient_given = false;
        self.fields_block(keyword, &["color", "ambientLight"], |p, field| {
            let value = p.vec3()?.0;
            match field.text {
                "color" => background.color = value,
                _ => (background.ambient, ambient_given) = (value, true),
            }
            Ok(())
        })?;
        Ok(BackgroundBlock { background, ambient_given })
    }

    fn materials(&mut self, keyword: Token<'a>) -> Result<Vec<MaterialEntry>> {
        const ITEMS: &str = MATERIAL_KINDS;
        self.open(keyword)?;
        let mut count = self.count_field(keyword, "numMaterials", "materials")?;
        let mut materials = Vec::new();
        loop {
            let token = self.expect(ITEMS)?;
            match token.text {
                "}" => {
                    self.check_shortfall(&count, token)?;
                    break;
                }
                "Material" | "PhongMaterial" => {
                    self.check_extra(&mut count, token)?;
                    materials.push((self.material(token)?, None, token.location));
                }
                "Checkerboard" | "Noise" | "Marble" | "Wood" => {
                    self.check_extra(&mut count, token)?;
                    let texture = self.texture(token, materials.len())?;
                    self.check_texture_nesting(&texture, &materials, token)?;
                    // The course's OpenGL preview shows a texture as its first material.
                    let stand_in = materials[texture.materials[0] as usize].0;
                    materials.push((stand_in, Some(texture), token.location));
                }
                _ => return Err(self.unknown(token, "material", ITEMS)),
            }
        }
        self.material_count = Some(materials.len());
        Ok(materials)
    }

    /// `Material` and `PhongMaterial` are synonyms (GRAMMAR.md A3), with the same fields.
    fn material(&mut self, keyword: Token<'a>) -> Result<Material> {
        let mut material = Material::default();
        self.fields_block(keyword, &PHONG_FIELDS, |p, field| {
            match field.text {
                "diffuseColor" => material.diffuse = p.vec3()?.0,
                "specularColor" => material.specular = p.vec3()?.0,
                "exponent" => material.exponent = p.number()?.0,
                "reflectiveColor" => material.reflective = p.vec3()?.0,
                "transparentColor" => material.transparent = p.vec3()?.0,
                _ => material.index_of_refraction = p.number()?.0,
            }
            Ok(())
        })?;
        Ok(material)
    }

    /// A solid texture block (GRAMMAR.md A6) that will be material `index`: an optional
    /// `Transform { … }`, `materialIndex I materialIndex J` naming earlier materials, and
    /// the kind's numbers (`octaves`; Marble and Wood also `frequency`, `amplitude`), each
    /// once, in any order.
    fn texture(&mut self, keyword: Token<'a>, index: usize) -> Result<Texture> {
        let kind = match keyword.text {
            "Checkerboard" => TextureKind::Checkerboard,
            "Noise" => TextureKind::Noise,
            "Marble" => TextureKind::Marble,
            _ => TextureKind::Wood,
        };
        let fields: &[&'static str] = match kind {
            TextureKind::Checkerboard => &["Transform", "materialIndex"],
            TextureKind::Noise => &["Transform", "materialIndex", "octaves"],
            TextureKind::Marble | TextureKind::Wood => {
                &["Transform", "materialIndex", "octaves", "frequency", "amplitude"]
            }
        };
        let mut texture = Texture {
            kind,
            to_texture: DMat4::IDENTITY,
            materials: [0; 2],
            octaves: 0,
            frequency: 0.0,
            amplitude: 0.0,
        };
        let (mut pair, mut octaves, mut frequency, mut amplitude) = (None, None, None, None);
        let close = self.fields_block(keyword, fields, |p, field| {
            match field.text {
                "Transform" => texture.to_texture = p.texture_transform(field)?,
                "materialIndex" => pair = Some(p.texture_materials(keyword, index)?),
                "octaves" => octaves = Some(p.octaves()?),
                "frequency" => frequency = Some(p.number()?.0),
                _ => amplitude = Some(p.number()?.0),
            }
            Ok(())
        })?;
        texture.materials = self.required(pair, keyword, "materialIndex", close)?;
        if kind != TextureKind::Checkerboard {
            texture.octaves = self.required(octaves, keyword, "octaves", close)?;
        }
        if matches!(kind, TextureKind::Marble | TextureKind::Wood) {
            texture.frequency = self.required(frequency, keyword, "frequency", close)?;
            texture.amplitude = self.required(amplitude, keyword, "amplitude", close)?;
        }
        Ok(texture)
    }

    fn check_texture_nesting(&self, texture: &Texture, earlier: &[MaterialEntry], keyword: Token) -> Result<()> {
        let depth = texture_depth(texture, earlier);
        if depth > MAX_TEXTURE_NESTING {
            return Err(self.error(
                keyword.location,
                format!(
                    "textures nested {depth} deep, more than {MAX_TEXTURE_NESTING}: each level may shade both \
                     of its materials, so a hit would cost up to 2^{depth} shadings"
                ),
            ));
        }
        Ok(())
    }

    /// `{ transformation* }` after a texture's `Transform`: the world → texture matrix,
    /// composed as an object's Transform composes. It need not be invertible: nothing maps
    /// back from texture space.
    fn texture_transform(&mut self, keyword: Token<'a>) -> Result<DMat4> {
        const EXPECTED: &str = "`}` or a transformation (Scale, UniformScale, Translate, XRotate, YRotate, \
             ZRotate, Rotate, Matrix)";
        self.open(keyword)?;
        let mut matrix = DMat4::IDENTITY;
        loop {
            let token = self.expect(EXPECTED)?;
            if token.text == "}" {
                return Ok(matrix);
            }
            if !TRANSFORMATIONS.contains(&token.text) {
                return Err(self.unknown_in(token, "transformation", "a texture's Transform", EXPECTED));
            }
            match self.transformation(token)? {
                Compose::After(step) => matrix *= step,
                Compose::Before(step) => matrix = step * matrix,
            }
        }
    }

    /// `I materialIndex J` after the first `materialIndex` of the texture that will be
    /// material `index`: both must name materials before it (the course asserts this).
    fn texture_materials(&mut self, keyword: Token<'a>, index: usize) -> Result<[u32; 2]> {
        let first = self.earlier_material(keyword, index)?;
        let token = self.expect("a second `materialIndex`")?;
        if token.text != "materialIndex" {
            return Err(self.unexpected(token, &format!("a second `materialIndex` in {}", keyword.text)));
        }
        Ok([first, self.earlier_material(keyword, index)?])
    }

    fn earlier_material(&mut self, keyword: Token<'a>, index: usize) -> Result<u32> {
        let (value, location) = self.count_value()?;
        if value >= index as u64 {
            return Err(self.error(
                location,
                format!(
                    "materialIndex {value} must name an earlier material: this {} is material {index}",
                    keyword.text
                ),
            ));
        }
        Ok(value as u32)
    }

    fn octaves(&mut self) -> Result<u32> {
        let (value, location) = self.count_value()?;
        if value > MAX_OCTAVES {
            return Err(self.error(
                location,
                format!("octaves {value} is more than {MAX_OCTAVES}: the octaves beyond add nothing an f64 holds"),
            ));
        }
        Ok(value as u32)
    }

    // ---- objects ----

    /// OBJECT, starting at `keyword` (one of [`OBJECT_KEYWORDS`]).
    ///
    /// Groups and Transforms nest, which makes this the one rule that would recurse without
    /// bound. It keeps the open blocks on an explicit stack instead, so nesting costs heap,
    /// not call stack, at any optimisation level. [`MAX_NESTING`] still applies: the tree is
    /// dropped, cloned and rendered recursively later.
    fn object(&mut self, keyword: Token<'a>) -> Result<Object> {
        let mut current = match self.begin_object(keyword, 1)? {
            Begun::Leaf(object) => return Ok(object),
            Begun::Block(block) => block,
        };
        let mut ancestors: Vec<OpenBlock<'a>> = Vec::new();
        loop {
            let finished = match self.next_item(&mut current)? {
                Item::Consumed => continue,
                Item::Object(token) => match self.begin_object(token, ancestors.len() + 2)? {
                    Begun::Leaf(object) => object,
                    Begun::Block(block) => {
                        ancestors.push(std::mem::replace(&mut current, block));
                        continue;
                    }
                },
                Item::Closed(object) => match ancestors.pop() {
                    None => return Ok(object),
                    Some(parent) => {
                        current = parent;
                        object
                    }
                },
            };
            current.adopt(finished);
        }
    }

    /// Reads the start of the object at `keyword`, which will sit at nesting `level`: a leaf
    /// is read whole, a `Group` or `Transform` up to its first item.
    fn begin_object(&mut self, keyword: Token<'a>, level: usize) -> Result<Begun<'a>> {
        let block = match keyword.text {
            "Group" | "Transform" if level > MAX_NESTING => {
                return Err(self.error(
                    keyword.location,
                    format!("nesting too deep: more than {MAX_NESTING} levels of Group/Transform"),
                ))
            }
            "Group" => {
                self.open(keyword)?;
                let count = self.count_field(keyword, "numObjects", "objects")?;
                OpenBlock::Group { keyword, count, children: Vec::new() }
            }
            "Transform" => {
                self.open(keyword)?;
                OpenBlock::Transform { keyword, matrix: DMat4::IDENTITY, child: None }
            }
            _ => return Ok(Begun::Leaf(self.leaf(keyword)?)),
        };
        Ok(Begun::Block(block))
    }

    /// Reads the next item of an open `Group` or `Transform`.
    fn next_item(&mut self, block: &mut OpenBlock<'a>) -> Result<Item<'a>> {
        match block {
            OpenBlock::Group { keyword, count, children } => {
                let token = self.expect(GROUP_ITEMS)?;
                match token.text {
                    "}" => {
                        self.check_shortfall(count, token)?;
                        let shape = Shape::Group(std::mem::take(children));
                        Ok(Item::Closed(Object { shape, location: keyword.location, fields: Default::default() }))
                    }
                    "MaterialIndex" => self.material_index().map(|()| Item::Consumed),
                    text if OBJECT_KEYWORDS.contains(&text) => {
                        self.check_extra(count, token)?;
                        Ok(Item::Object(token))
                    }
                    _ => Err(self.unknown(token, "object", GROUP_ITEMS)),
                }
            }
            OpenBlock::Transform { keyword, matrix, child } => {
                if let Some(object) = child.take() {
                    self.punctuation("}", "`}` after the Transform's object")?;
                    let shape = Shape::Transform { matrix: *matrix, child: object };
                    return Ok(Item::Closed(Object { shape, location: keyword.location, fields: Default::default() }));
                }
                let token = self.expect(TRANSFORM_ITEMS)?;
                if OBJECT_KEYWORDS.contains(&token.text) {
                    self.check_invertible(matrix, *keyword)?;
                    return Ok(Item::Object(token));
                }
                match self.transformation(token)? {
                    Compose::After(step) => *matrix *= step,
                    Compose::Before(step) => *matrix = step * *matrix,
                }
                Ok(Item::Consumed)
            }
        }
    }

    /// Sphere, Plane, Triangle or TriangleMesh.
    fn leaf(&mut self, keyword: Token<'a>) -> Result<Object> {
        let material = self.material_for(keyword)?;
        let mut fields = [Location::default(); 3];
        let shape = match keyword.text {
            "Sphere" => self.sphere(keyword, material, &mut fields)?,
            "Plane" => self.plane(keyword, material, &mut fields)?,
            "Triangle" => self.triangle(keyword, material, &mut fields)?,
            "TriangleMesh" => self.triangle_mesh(keyword, material)?,
            _ => return Err(self.unknown(keyword, "object", GROUP_ITEMS)),
        };
        Ok(Object { shape, location: keyword.location, fields })
    }

    fn material_for(&self, keyword: Token) -> Result<u32> {
        self.current_material.ok_or_else(|| {
            self.error(keyword.location, format!("{} before any MaterialIndex: objects need a material", keyword.text))
        })
    }

    /// `MaterialIndex I`: the material of every object that follows in the file.
    fn material_index(&mut self) -> Result<()> {
        let (index, location) = self.count_value()?;
        let known_count = self.material_count;
        let index = match u32::try_from(index) {
            Ok(index) if known_count.is_none_or(|n| (index as usize) < n) => index,
            _ => return Err(self.material_out_of_range(index, known_count.unwrap_or(0), location)),
        };
        if known_count.is_none() {
            self.unchecked_material_refs.push((index, location));
        }
        self.current_material = Some(index);
        Ok(())
    }

    fn sphere(&mut self, keyword: Token<'a>, material: u32, at: &mut [Location; 3]) -> Result<Shape> {
        let (mut center, mut radius) = (None, None);
        let close = self.fields_block(keyword, &["center", "radius"], |p, field| {
            at[usize::from(field.text != "center")] = field.location;
            match field.text {
                "center" => center = Some(p.vec3()?.0),
                _ => radius = Some(p.positive("radius")?),
            }
            Ok(())
        })?;
        Ok(Shape::Sphere {
            center: self.required(center, keyword, "center", close)?,
            radius: self.required(radius, keyword, "radius", close)?,
            material,
        })
    }

    fn plane(&mut self, keyword: Token<'a>, material: u32, at: &mut [Location; 3]) -> Result<Shape> {
        let (mut normal, mut offset) = (None, None);
        let close = self.fields_block(keyword, &["normal", "offset"], |p, field| {
            at[usize::from(field.text != "normal")] = field.location;
            match field.text {
                "normal" => normal = Some(p.nonzero_vec3("plane normal")?),
                _ => offset = Some(p.number()?.0),
            }
            Ok(())
        })?;
        Ok(Shape::Plane {
            normal: self.required(normal, keyword, "normal", close)?,
            offset: self.required(offset, keyword, "offset", close)?,
            material,
        })
    }

    fn triangle(&mut self, keyword: Token<'a>, material: u32, at: &mut [Location; 3]) -> Result<Shape> {
        const FIELDS: [&str; 3] = ["vertex0", "vertex1", "vertex2"];
        let mut vertices = [None; 3];
        let close = self.fields_block(keyword, &FIELDS, |p, field| {
            let index = FIELDS.iter().position(|f| *f == field.text);
            if let Some((slot, place)) = index.and_then(|i| vertices.get_mut(i).zip(at.get_mut(i))) {
                *slot = Some(p.vec3()?.0);
                *place = field.location;
            }
            Ok(())
        })?;
        let [v0, v1, v2] = vertices;
        Ok(Shape::Triangle {
            vertices: [
                self.required(v0, keyword, "vertex0", close)?,
                self.required(v1, keyword, "vertex1", close)?,
                self.required(v2, keyword, "vertex2", close)?,
            ],
            material,
        })
    }

    fn triangle_mesh(&mut self, keyword: Token<'a>, material: u32) -> Result<Shape> {
        let mut mesh = None;
        let close = self.fields_block(keyword, &["obj_file"], |p, _| {
            let token = p.expect("an OBJ file path")?;
            if token.text == "{" || token.text == "}" {
                return Err(p.unexpected(token, "an OBJ file path"));
            }
            mesh = Some(p.mesh(token)?);
            Ok(())
        })?;
        Ok(Shape::Mesh { mesh: self.required(mesh, keyword, "obj_file", close)?, material })
    }

    /// Loads (or reuses) the mesh named by `token`.
    fn mesh(&mut self, token: Token) -> Result<Arc<Mesh>> {
        let path = self.resolve_obj_path(token)?;
        let key = match self.files {
            ObjFiles::Disk => fs::canonicalize(&path).unwrap_or_else(|_| path.clone()),
            ObjFiles::Memory(_) => path.clone(),
        };
        if let Some(mesh) = self.meshes.get(&key) {
            return Ok(Arc::clone(mesh));
        }
        let loaded = match self.files {
            ObjFiles::Disk => load_obj(&path),
            ObjFiles::Memory(files) => parse_obj(&files[&path], &path),
        };
        let mesh = Arc::new(loaded.map_err(|mut error| {
            let Location { line, col } = token.location;
            error.message = format!("{} (obj_file of {}:{line}:{col})", error.message, self.path.display());
            error
        })?);
        self.meshes.insert(key, Arc::clone(&mesh));
        Ok(mesh)
    }

    /// `obj_file` paths are relative to the scene file's folder, then the working directory.
    /// Only regular files qualify (a device such as `/dev/zero` would never end).
    fn resolve_obj_path(&self, token: Token) -> Result<PathBuf> {
        let name = Path::new(token.text);
        let folder = self.path.parent().unwrap_or(Path::new(""));
        let mut not_regular = None;
        for candidate in [folder.join(name), name.to_path_buf()] {
            // Some(whether it is a regular file), None where nothing is there.
            let is_file = match self.files {
                ObjFiles::Disk => fs::metadata(&candidate).ok().map(|m| m.is_file()),
                ObjFiles::Memory(files) => files.contains_key(&candidate).then_some(true),
            };
            match is_file {
                Some(true) => return Ok(candidate),
                Some(false) => not_regular = not_regular.or(Some(candidate)),
                None => {}
            }
        }
        let message = match not_regular {
            Some(path) => format!("obj_file {}: `{}` is not a regular file", describe(token.text), path.display()),
            None => format!(
                "obj_file {} not found (looked in `{}` and in the working directory)",
                describe(token.text),
                folder.display()
            ),
        };
        Err(self.error(token.location, message))
    }

    fn transformation(&mut self, token: Token<'a>) -> Result<Compose> {
        let step = match token.text {
            "Scale" => DMat4::from_scale(self.vec3()?.0),
            "UniformScale" => DMat4::from_scale(DVec3::splat(self.number()?.0)),
            "Translate" => DMat4::from_translation(self.vec3()?.0),
            "XRotate" => DMat4::from_rotation_x(self.number()?.0.to_radians()),
            "YRotate" => DMat4::from_rotation_y(self.number()?.0.to_radians()),
            "ZRotate" => DMat4::from_rotation_z(self.number()?.0.to_radians()),
            "Rotate" => self.rotate(token)?,
            "Matrix" => return Ok(Compose::Before(self.matrix(token)?)),
            _ => return Err(self.unknown(token, "transformation", TRANSFORM_ITEMS)),
        };
        Ok(Compose::After(step))
    }

    /// `Rotate { axis degrees }`: a right-handed rotation about the (normalised) axis.
    fn rotate(&mut self, keyword: Token) -> Result<DMat4> {
        self.open(keyword)?;
        let (axis, axis_location) = self.vec3()?;
        let (degrees, _) = self.number()?;
        self.punctuation("}", "`}` after the Rotate angle")?;
        // Dividing by the largest component first keeps huge axes from overflowing.
        let axis = (axis / axis.abs().max_element())
            .try_normalize()
            .ok_or_else(|| self.error(axis_location, "Rotate axis must not be the zero vector"))?;
        Ok(DMat4::from_axis_angle(axis, degrees.to_radians()))
    }

    /// `Matrix { 16 numbers }`, row-major; it must be affine (last row `0 0 0 1`).
    fn matrix(&mut self, keyword: Token) -> Result<DMat4> {
        self.open(keyword)?;
        let mut rows = [0.0; 16];
        for value in &mut rows {
            *value = self.number()?.0;
        }
        self.punctuation("}", "`}` after the 16 numbers of Matrix")?;
        let matrix = DMat4::from_cols_array(&rows).transpose();
        let last_row = matrix.row(3);
        if last_row != DVec4::W {
            return Err(self.error(
                keyword.location,
                format!("Matrix must be affine: its last row must be 0 0 0 1, found {}", show4(last_row)),
            ));
        }
        Ok(matrix)
    }

    fn check_invertible(&self, matrix: &DMat4, keyword: Token) -> Result<()> {
        match singularity(matrix) {
            Some(message) => Err(self.error(keyword.location, message)),
            None => Ok(()),
        }
    }
}

/// Why `matrix` cannot be inverted reliably, if it cannot: a linear part whose determinant
/// is 0 or tiny relative to its largest entry (|det| ≤ 1e-12·max³, tested on the matrix
/// divided by max so that the test itself cannot overflow), or entries or a determinant
/// that f64 cannot hold (the renderers compute `M⁻¹` through `1/det`).
/// How many textures deep `texture` goes: 1, plus the deepest of its materials' depths.
fn texture_depth(texture: &Texture, earlier: &[MaterialEntry]) -> usize {
    let below = texture.materials.iter().filter_map(|&m| earlier[m as usize].1.as_ref());
    1 + below.map(|t| texture_depth(t, earlier)).max().unwrap_or(0)
}

fn singularity(matrix: &DMat4) -> Option<String> {
    let linear = DMat3::from_mat4(*matrix);
    let determinant = linear.determinant();
    if !matrix.is_finite() || !determinant.is_finite() {
        return Some("transform overflows: its entries or determinant are non-finite".to_string());
    }
    let largest = linear.to_cols_array().iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    if largest == 0.0 || determinant == 0.0 {
        return Some("singular transform (determinant 0)".to_string());
    }
    let relative = (linear * (1.0 / largest)).determinant();
    let invertible = relative.abs() > 1e-12 && (1.0 / determinant).is_finite();
    (!invertible).then(|| format!("singular transform (determinant {determinant:e}, too close to 0)"))
}

/// Why a camera has no frame ([`CameraBasis::new`](super::model::CameraBasis::new) failed):
/// almost always `up` ∥ `direction`; otherwise (both checked after scaling to unit size, so
/// extremes cannot hide the answer) a vector f64 cannot normalise, such as `1e-200 0 0`.
fn degenerate_camera_message(direction: DVec3, up: DVec3) -> String {
    let unit_scale = |v: DVec3| v / v.abs().max_element();
    let (unit_up, unit_direction) = (unit_scale(up), unit_scale(direction));
    if unit_up.cross(unit_direction).length() <= 1e-12 * unit_up.length() {
        format!("up ({}) is parallel to direction ({})", show(up), show(direction))
    } else {
        format!("direction ({}) and up ({}) are too large or too small to normalise", show(direction), show(up))
    }
}

fn no_lights_warning(background: &BackgroundBlock) -> String {
    let mut warning = "no lights: ambient light set to 1 1 1 (flat colour)".to_string();
    if background.ambient_given {
        warning += &format!(", replacing the file's ambientLight {}", show(background.background.ambient));
    }
    warning
}

fn show(v: DVec3) -> String {
    format!("{} {} {}", show1(v.x), show1(v.y), show1(v.z))
}

fn show4(v: DVec4) -> String {
    format!("{} {} {} {}", show1(v.x), show1(v.y), show1(v.z), show1(v.w))
}

/// A number as a person would write it in the file: plain, or with an exponent when plain
/// notation would run to dozens of digits.
fn show1(x: f64) -> String {
    if x != 0.0 && !(1e-4..1e15).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}
