//! Scene front end: lexer, parser and OBJ reader, producing the typed [`model`].
//!
//! Entry points: [`load_scene`] / [`parse_scene`] for scene files (docs/SPEC.md §2) and
//! [`load_obj`] / [`parse_obj`] for meshes. Every failure is a [`SceneError`] that names
//! the file, line and column; no input makes them panic.

mod error;
pub mod generate;
mod lexer;
mod measure;
pub mod model;
mod obj;
mod parser;
pub mod walk;

pub use error::{SceneError, SceneWarning};
pub use model::*;
pub use obj::{load_obj, parse_obj};
pub use parser::{
    load_scene, obj_file_names, parse_scene, parse_scene_with, ObjFiles, MAX_NESTING, MAX_OCTAVES, MAX_TEXTURE_NESTING,
};
pub use walk::{for_each_leaf, try_for_each_leaf, Leaf};
