//! The fused test mode (`RAYCASTER_FUSE_MUL_ADD=1`): the kernel as a driver that fuses
//! every multiply-add would compile it. WGSL lets a compiler evaluate `a * b + c` as one
//! fused multiply-add, and `dot` and `cross` in any order of fused steps; NVIDIA's does, while
//! the CPU drivers we test on (lavapipe, SwiftShader) do not, and compile even an explicit
//! `fma` as a multiply and an add (docs/SPEC.md §6, "What the kernel assumes of the
//! driver"). So the pass cannot just write `fma`: a driver would fold it back.
//!
//! Instead each multiply feeding an add or a subtraction, each `fma`, `dot` and `cross` of
//! f32 values becomes a call of a helper that computes it in f64 and rounds once to f32:
//! the product of two f32 values is exact in f64, so the result is the fused one (up to
//! the second rounding, f64 to f32, which differs from a single one in about one case in
//! 2²⁹) and no driver can turn it back into two roundings. A product wrapped in
//! `rounded()` (shaders/exact.wgsl) is, by design, not fused: that is what the wrapper is for.
//!
//! The helpers are WGSL ([`prelude`], composed before the kernel's files: a function may
//! only call functions declared before it in naga's IR); the pass swaps an expression for
//! a call in place, so no handle moves. It runs once on the whole kernel, before the
//! specialiser cuts it down (which drops the helpers nothing calls).

use naga::{BinaryOperator, Block, Expression, Function, Handle, MathFunction, Module, Statement, TypeInner};
use std::collections::HashMap;
use std::fmt::Write;

/// The variable that switches the fused mode on, for the tests and for checks outside them.
pub const VARIABLE: &str = "RAYCASTER_FUSE_MUL_ADD";

/// Whether the environment asks for the fused mode (`RAYCASTER_FUSE_MUL_ADD=1`).
pub fn requested() -> bool {
    std::env::var(VARIABLE).is_ok_and(|v| v == "1")
}

/// The WGSL shapes an f32 operand can take: a scalar, or a vector of 2, 3 or 4.
const SHAPES: [&str; 4] = ["s", "v2", "v3", "v4"];

fn f32_type(shape: &str) -> String {
    match shape {
        "s" => "f32".into(),
        v => format!("vec{}<f32>", &v[1..]),
    }
}

fn to_f64(shape: &str, name: &str) -> String {
    match shape {
        "s" => format!("f64({name})"),
        v => format!("vec{}<f64>({name})", &v[1..]),
    }
}

/// The helpers, one per operation and operand shapes: `fused_add_v3_s_v3(a, b, c)` is
/// `a * b + c` for a vec3, a scalar and a vec3, `sub` is `a * b - c`, `rsub` is `c - a * b`.
pub fn prelude() -> String {
    let mut out = String::from("// The fused mode's helpers (src/gpu/fuse.rs).\n");
    for size in 1..=4usize {
        let shapes: Vec<&str> = if size == 1 { vec!["s"] } else { vec!["s", SHAPES[size - 1]] };
        let result = SHAPES[size - 1];
        for &a in &shapes {
            for &b in &shapes {
                for &c in &shapes {
                    if size > 1 && a == "s" && b == "s" && c == "s" {
                        continue;
                    }
                    let (pa, pb, pc) = (to_f64(a, "a"), to_f64(b, "b"), to_f64(c, "c"));
                    for (op, body) in [
                        ("add", format!("{pa} * {pb} + {pc}")),
                        ("sub", format!("{pa} * {pb} - {pc}")),
                        ("rsub", format!("{pc} - {pa} * {pb}")),
                    ] {
                        let _ = writeln!(
                            out,
                            "fn fused_{op}_{a}_{b}_{c}(a: {}, b: {}, c: {}) -> {} {{ return {}({body}); }}",
                            f32_type(a),
                            f32_type(b),
                            f32_type(c),
                            f32_type(result),
                            f32_type(result),
                        );
                    }
                }
            }
        }
        if size > 1 {
            let v = SHAPES[size - 1];
            let _ = writeln!(
                out,
                "fn fused_dot_{v}(a: {t}, b: {t}) -> f32 {{ return f32(dot({}, {})); }}",
                to_f64(v, "a"),
                to_f64(v, "b"),
                t = f32_type(v)
            );
        }
    }
    out.push_str("fn fused_cross(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> { return vec3<f32>(cross(vec3<f64>(a), vec3<f64>(b))); }\n");
    out
}

/// Swaps every multiply-add, `fma`, `dot` and `cross` of f32 values in `module`'s functions
/// and entry points for a call of its fused helper; the name of the function of each one
/// swapped. The module must hold the [`prelude`]'s helpers (compose it first) and validate.
pub fn fuse(module: &mut Module) -> Vec<String> {
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(module)
        .unwrap_or_else(|e| panic!("the kernel validates before fusing: {e:?}"));
    let helpers: HashMap<String, Handle<Function>> = module
        .functions
        .iter()
        .filter_map(|(h, f)| f.name.as_ref().filter(|n| n.starts_with("fused_")).map(|n| (n.clone(), h)))
        .collect();
    let types = module.types.clone();
    let mut fused = Vec::new();
    for (handle, function) in module.functions.iter_mut() {
        if function.name.as_ref().is_some_and(|n| n.starts_with("fused_")) {
            continue;
        }
        let shape = |e: Handle<Expression>| shape_of(info[handle][e].ty.inner_with(&types));
        let n = fuse_function(function, &shape, &helpers);
        fused.extend(std::iter::repeat_n(function.name.clone().unwrap_or_default(), n));
    }
    for (index, entry) in module.entry_points.iter_mut().enumerate() {
        let function_info = info.get_entry_point(index);
        let shape = |e: Handle<Expression>| shape_of(function_info[e].ty.inner_with(&types));
        let n = fuse_function(&mut entry.function, &shape, &helpers);
        fused.extend(std::iter::repeat_n(entry.name.clone(), n));
    }
    fused
}

/// An f32 scalar's or vector's shape (one of [`SHAPES`]); `None` for anything else.
fn shape_of(inner: &TypeInner) -> Option<&'static str> {
    let f32 = naga::Scalar::F32;
    match *inner {
        TypeInner::Scalar(s) if s == f32 => Some("s"),
        TypeInner::Vector { size, scalar } if scalar == f32 => Some(SHAPES[size as usize - 1]),
        _ => None,
    }
}

/// A fused call: the helper's name and its arguments.
type Fused = (String, Vec<Handle<Expression>>);

fn fuse_function(
    function: &mut Function,
    shape: &dyn Fn(Handle<Expression>) -> Option<&'static str>,
    helpers: &HashMap<String, Handle<Function>>,
) -> usize {
    let exprs = &function.expressions;
    let product = |e: Handle<Expression>| match exprs[e] {
        Expression::Binary { op: BinaryOperator::Multiply, left, right } => {
            Some((left, right)).filter(|_| shape(left).is_some() && shape(right).is_some() && shape(e).is_some())
        }
        _ => None,
    };
    let mut calls: HashMap<Handle<Expression>, Fused> = HashMap::new();
    for (h, expression) in exprs.iter() {
        let Some(result) = shape(h) else { continue };
        let call = match *expression {
            Expression::Binary { op: op @ (BinaryOperator::Add | BinaryOperator::Subtract), left, right } => {
                let subtract = op == BinaryOperator::Subtract;
                if let Some((a, b)) = product(left) {
                    Some((if subtract { "sub" } else { "add" }, vec![a, b, right]))
                } else {
                    product(right).map(|(a, b)| (if subtract { "rsub" } else { "add" }, vec![a, b, left]))
                }
            }
            Expression::Math { fun: MathFunction::Fma, arg, arg1: Some(b), arg2: Some(c), .. } => {
                Some(("add", vec![arg, b, c]))
            }
            Expression::Math { fun: MathFunction::Dot, arg, arg1: Some(b), .. } => {
                shape(arg).filter(|&s| s != "s" && result == "s").map(|_| ("dot", vec![arg, b]))
            }
            Expression::Math { fun: MathFunction::Cross, arg, arg1: Some(b), .. } => Some(("cross", vec![arg, b])),
            _ => None,
        };
        let Some((op, args)) = call else { continue };
        let name = match op {
            "dot" => format!("fused_dot_{}", shape(args[0]).unwrap()),
            "cross" => "fused_cross".to_string(),
            _ => format!("fused_{op}_{}", args.iter().map(|&a| shape(a).unwrap_or("?")).collect::<Vec<_>>().join("_")),
        };
        if helpers.contains_key(&name) {
            calls.insert(h, (name, args));
        }
    }
    let mut swapped = 0;
    function.body = call_helpers(std::mem::take(&mut function.body), &calls, helpers, &mut swapped);
    for (h, (name, _)) in &calls {
        function.expressions[*h] = Expression::CallResult(helpers[name]);
    }
    assert_eq!(swapped, calls.len(), "every fused expression was emitted in a block");
    swapped
}

/// `block` with each emitted expression of `calls` taken out of its `Emit` range and
/// computed by a call instead, at the same place.
fn call_helpers(
    block: Block,
    calls: &HashMap<Handle<Expression>, Fused>,
    helpers: &HashMap<String, Handle<Function>>,
    swapped: &mut usize,
) -> Block {
    let mut out = Block::with_capacity(block.len());
    for (statement, span) in block.span_into_iter() {
        let statement = match statement {
            Statement::Emit(range) => {
                let mut start: Option<Handle<Expression>> = None;
                let mut last: Option<Handle<Expression>> = None;
                for h in range.clone() {
                    if let Some((name, args)) = calls.get(&h) {
                        if let (Some(s), Some(l)) = (start.take(), last.take()) {
                            out.push(Statement::Emit(naga::Range::new_from_bounds(s, l)), span);
                        }
                        out.push(
                            Statement::Call { function: helpers[name], arguments: args.clone(), result: Some(h) },
                            span,
                        );
                        *swapped += 1;
                    } else {
                        start.get_or_insert(h);
                        last = Some(h);
                    }
                }
                if let (Some(s), Some(l)) = (start, last) {
                    out.push(Statement::Emit(naga::Range::new_from_bounds(s, l)), span);
                }
                continue;
            }
            Statement::Block(inner) => Statement::Block(call_helpers(inner, calls, helpers, swapped)),
            Statement::If { condition, accept, reject } => Statement::If {
                condition,
                accept: call_helpers(accept, calls, helpers, swapped),
                reject: call_helpers(reject, calls, helpers, swapped),
            },
            Statement::Loop { body, continuing, break_if } => Statement::Loop {
                body: call_helpers(body, calls, helpers, swapped),
                continuing: call_helpers(continuing, calls, helpers, swapped),
                break_if,
            },
            Statement::Switch { selector, cases } => Statement::Switch {
                selector,
                cases: cases
                    .into_iter()
                    .map(|case| naga::SwitchCase { body: call_helpers(case.body, calls, helpers, swapped), ..case })
                    .collect(),
            },
            other => other,
        };
        out.push(statement, span);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fused(source: &str) -> (Module, usize) {
        let mut module = naga::front::wgsl::parse_str(&format!("{}{source}", prelude())).unwrap();
        let n = fuse(&mut module).len();
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
            .validate(&module)
            .expect("the fused module validates");
        (module, n)
    }

    #[test]
    fn every_multiply_add_of_f32_values_is_fused_and_nothing_else() {
        let (_, n) = fused(
            "@group(0) @binding(0) var<storage, read_write> out: array<f32>;
             @group(0) @binding(1) var<storage, read_write> ints: array<u32>;
             @compute @workgroup_size(1) fn main(@builtin(global_invocation_id) id: vec3<u32>) {
                 let a = out[0]; let b = out[1]; let c = out[2];
                 let v = vec3<f32>(a, b, c);
                 out[3] = a * b + c;                  // fused
                 out[4] = c - a * b;                  // fused
                 out[5] = (v * a - v).x;              // fused
                 out[6] = dot(v, v) + cross(v, v).y;  // dot and cross fused, their sum not
                 out[7] = fma(a, b, c);               // fused
                 out[8] = a * b;                      // nothing to fuse with
                 out[9] = bitcast<f32>(bitcast<u32>(a * b) | ints[0]) + c; // rounded(): not fused
                 ints[1] = ints[2] * id.x + 1u;       // integers: not fused
             }",
        );
        assert_eq!(n, 6);
    }

    /// The audit of docs/SPEC.md §6: what a driver may still fuse in the kernel lies in the
    /// shading alone (colours, lights, noise); every product that decides a hit, a cell, a
    /// shadow or a side is rounded on its own (shaders/exact.wgsl), so none is found there.
    #[test]
    fn only_shading_is_left_for_a_driver_to_fuse() {
        let (module, fused) = super::super::shader::fused_module();
        let mut places: Vec<&str> = fused.iter().map(String::as_str).collect();
        places.dedup();
        println!("{} multiply-adds, dots and crosses fused, in {places:?}", fused.len());
        // Colours: lights, the Phong terms, noise, marble's and wood's bands, blends, the ray
        // tree's sum, filter weights.
        let shading = [
            "incoming",
            "local",
            "shade_phong",
            "shade_blend",
            "fade",
            "first_material_share",
            "color_of_tree",
            "add_sample",
        ];
        let deciding: Vec<&&str> = places.iter().filter(|p| !shading.contains(p)).collect();
        assert!(deciding.is_empty(), "multiply-adds left to the driver outside the shading: {deciding:?}");
        assert!(fused.len() >= 10, "the fused mode finds the shading's multiply-adds: {}", fused.len());
        let mut again = module.clone();
        assert_eq!(fuse(&mut again).len(), 0, "fusing twice finds nothing new");
        for entry in ["main", "main_bins", "main_samples", "main_filter"] {
            super::super::specialise::specialise(module, &[], entry);
        }
    }
}
