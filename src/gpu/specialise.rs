//! One kernel per [`KernelConfig`](super::KernelConfig), cut down before the driver sees
//! it. The kernel is one WGSL module whose features hang on `override` switches
//! (`if (TEXTURES && …)`, `if (!TREE)`). Handed to wgpu as it is, with the
//! switches as pipeline constants, every feature's code still reaches the driver behind a
//! branch that never runs, and lavapipe inlines and optimises all of it before it finds
//! out: a small render spent most of its time preparing its kernel, in lavapipe's own
//! passes (`perf`, docs/performance.md), which its shader cache does not save.
//!
//! So the host fixes the overrides itself (naga's `process_overrides`), cuts every branch
//! whose condition has become a known constant, drops the entry point it does not run,
//! and lets naga's `compact` remove the functions nothing calls any more. wgpu gets a
//! module without overrides, holding only what this kernel runs. Nothing that runs
//! changes: a branch is cut only where its condition is a constant of the module.

use naga::{BinaryOperator, Block, Expression, Literal, Module, Statement, UnaryOperator};
use std::collections::HashMap;

/// The kernel's module parsed once, for [`specialise`] to copy.
pub fn parse(source: &str) -> Module {
    naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("the kernel parses: {}", e.emit_to_string(source)))
}

/// `module` with `constants` fixed, the branches they decide cut, and only `entry_point`
/// and what it calls left.
pub fn specialise(module: &Module, constants: &[(&str, f64)], entry_point: &str) -> Module {
    let info = validate(module);
    let constants: naga::back::PipelineConstants =
        constants.iter().map(|&(name, value)| (name.to_string(), value)).collect();
    let (fixed, _) = naga::back::pipeline_constants::process_overrides(
        module,
        &info,
        Some((naga::ShaderStage::Compute, entry_point)),
        &constants,
    )
    .unwrap_or_else(|e| panic!("the kernel's overrides take the host's values: {e}"));
    let mut module = fixed.into_owned();
    module.entry_points.retain(|e| e.name == entry_point);
    let constant_values = ConstantValues::of(&module);
    for (_, function) in module.functions.iter_mut() {
        cut_function(function, &constant_values);
    }
    for entry in &mut module.entry_points {
        cut_function(&mut entry.function, &constant_values);
    }
    naga::compact::compact(&mut module, naga::compact::KeepUnused::No);
    validate(&module);
    module
}

/// The kernel as wgpu takes it: naga's IR.
#[cfg(not(target_arch = "wasm32"))]
pub fn shader_source(module: Module) -> wgpu::ShaderSource<'static> {
    wgpu::ShaderSource::Naga(std::borrow::Cow::Owned(module))
}

/// The kernel as a browser takes it: WGSL. wgpu would write it with naga, which spells
/// `f32::MAX` `340282350000000000000000000000000000000f`, and Chromium's Tint refuses
/// that ("value cannot be represented as 'f32'": the decimal lies above `f32::MAX` before
/// rounding). The same value in hexadecimal is exact.
#[cfg(target_arch = "wasm32")]
pub fn shader_source(module: Module) -> wgpu::ShaderSource<'static> {
    let info = validate(&module);
    let wgsl = naga::back::wgsl::write_string(&module, &info, naga::back::wgsl::WriterFlags::empty())
        .unwrap_or_else(|e| panic!("naga writes the kernel as WGSL: {e}"));
    wgpu::ShaderSource::Wgsl(std::borrow::Cow::Owned(wgsl.replace(&format!("{}f", f32::MAX), "0x1.fffffep+127f")))
}

fn validate(module: &Module) -> naga::valid::ModuleInfo {
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(module)
        .unwrap_or_else(|e| panic!("the kernel validates: {e:?}"))
}

/// The module's constants whose value is a boolean or integer literal, by handle.
struct ConstantValues(HashMap<naga::Handle<naga::Constant>, Literal>);

impl ConstantValues {
    fn of(module: &Module) -> ConstantValues {
        let values = module
            .constants
            .iter()
            .filter_map(|(handle, c)| match module.global_expressions[c.init] {
                Expression::Literal(l @ (Literal::Bool(_) | Literal::U32(_) | Literal::I32(_))) => Some((handle, l)),
                _ => None,
            })
            .collect();
        ConstantValues(values)
    }
}

/// What is known to hold a constant boolean in one function: the module's boolean
/// constants, and the hidden variables through which naga lowers WGSL's short-circuiting
/// `a && b` (`var t; if (a) { t = b; } else { t = false; }`, then `t`) once every store
/// left to one of them stores the same known value.
struct Known<'a> {
    constants: &'a ConstantValues,
    locals: HashMap<naga::Handle<naga::LocalVariable>, bool>,
}

impl Known<'_> {
    /// The value of the boolean expression `e`, where the known values alone decide it: a
    /// literal, a constant, a load of a known hidden variable, `!`, a comparison of known
    /// integers, and `&&`/`||` with a deciding side (`LogicalAnd`/`LogicalOr` in naga's IR
    /// have no effects to keep).
    fn bool(&self, e: naga::Handle<Expression>, exprs: &naga::Arena<Expression>) -> Option<bool> {
        let known = |e| self.bool(e, exprs);
        match exprs[e] {
            Expression::Literal(Literal::Bool(b)) => Some(b),
            Expression::Constant(c) => match self.constants.0.get(&c) {
                Some(Literal::Bool(b)) => Some(*b),
                _ => None,
            },
            Expression::Load { pointer } => match exprs[pointer] {
                Expression::LocalVariable(v) => self.locals.get(&v).copied(),
                _ => None,
            },
            Expression::Unary { op: UnaryOperator::LogicalNot, expr } => known(expr).map(|b| !b),
            Expression::Binary { op: BinaryOperator::LogicalAnd, left, right } => match (known(left), known(right)) {
                (Some(false), _) | (_, Some(false)) => Some(false),
                (Some(true), Some(true)) => Some(true),
                _ => None,
            },
            Expression::Binary { op: BinaryOperator::LogicalOr, left, right } => match (known(left), known(right)) {
                (Some(true), _) | (_, Some(true)) => Some(true),
                (Some(false), Some(false)) => Some(false),
                _ => None,
            },
            Expression::Binary { op, left, right } => {
                compare(op, self.integer(left, exprs)?, self.integer(right, exprs)?)
            }
            _ => None,
        }
    }

    /// The value of the integer expression `e` where it is a literal or a constant.
    fn integer(&self, e: naga::Handle<Expression>, exprs: &naga::Arena<Expression>) -> Option<i64> {
        let literal = match exprs[e] {
            Expression::Literal(l) => l,
            Expression::Constant(c) => *self.constants.0.get(&c)?,
            _ => return None,
        };
        match literal {
            Literal::U32(v) => Some(v as i64),
            Literal::I32(v) => Some(v as i64),
            _ => None,
        }
    }
}

/// `a op b` where `op` compares.
fn compare(op: BinaryOperator, a: i64, b: i64) -> Option<bool> {
    Some(match op {
        BinaryOperator::Equal => a == b,
        BinaryOperator::NotEqual => a != b,
        BinaryOperator::Less => a < b,
        BinaryOperator::LessEqual => a <= b,
        BinaryOperator::Greater => a > b,
        BinaryOperator::GreaterEqual => a >= b,
        _ => return None,
    })
}

/// Cuts the decided branches of `function` until none is left: each cut may leave a
/// hidden variable of `&&` with one known store, which decides the next branch.
fn cut_function(function: &mut naga::Function, constants: &ConstantValues) {
    // Names of `let` values, for the driver's debug output only: `compact` keeps a named
    // value alive, and one named in a cut branch (a call's result) would name what is gone.
    function.named_expressions.clear();
    loop {
        let known = Known { constants, locals: hidden_locals_known(function, constants) };
        if !cut_decided_branches(&mut function.body, &function.expressions, &known) {
            return;
        }
    }
}

/// The unnamed variables without initialiser (naga's own, for `&&` and `||`) whose stores
/// all store one known value: a load of one of them reads that value, since naga stores
/// to it on every path before it reads it.
fn hidden_locals_known(
    function: &naga::Function,
    constants: &ConstantValues,
) -> HashMap<naga::Handle<naga::LocalVariable>, bool> {
    let no_locals = Known { constants, locals: HashMap::new() };
    let mut stored: HashMap<naga::Handle<naga::LocalVariable>, Option<bool>> = HashMap::new();
    visit_statements(&function.body, &mut |statement| {
        if let Statement::Store { pointer, value } = *statement {
            if let Expression::LocalVariable(v) = function.expressions[pointer] {
                let value = no_locals.bool(value, &function.expressions);
                let entry = stored.entry(v).or_insert(value);
                if *entry != value {
                    *entry = None;
                }
            }
        }
    });
    stored
        .into_iter()
        .filter(|(v, _)| {
            let local = &function.local_variables[*v];
            local.name.is_none() && local.init.is_none()
        })
        .filter_map(|(v, value)| value.map(|b| (v, b)))
        .collect()
}

/// Calls `f` on every statement of `block` and of the blocks inside it.
fn visit_statements(block: &Block, f: &mut impl FnMut(&Statement)) {
    for statement in block {
        f(statement);
        match statement {
            Statement::Block(inner) => visit_statements(inner, f),
            Statement::If { accept, reject, .. } => {
                visit_statements(accept, f);
                visit_statements(reject, f);
            }
            Statement::Loop { body, continuing, .. } => {
                visit_statements(body, f);
                visit_statements(continuing, f);
            }
            Statement::Switch { cases, .. } => cases.iter().for_each(|case| visit_statements(&case.body, f)),
            _ => {}
        }
    }
}

/// Replaces every `if` whose condition `known` decides with the branch taken, in `block`
/// and every block inside it; whether it replaced any.
fn cut_decided_branches(block: &mut Block, exprs: &naga::Arena<Expression>, known: &Known) -> bool {
    let old = std::mem::take(block);
    let mut cut = false;
    for (mut statement, span) in old.span_into_iter() {
        if let Statement::If { condition, accept, reject } = &mut statement {
            if let Some(taken) = known.bool(*condition, exprs) {
                statement = Statement::Block(std::mem::take(if taken { accept } else { reject }));
                cut = true;
            }
        }
        match &mut statement {
            Statement::Block(inner) => cut |= cut_decided_branches(inner, exprs, known),
            Statement::If { accept, reject, .. } => {
                cut |= cut_decided_branches(accept, exprs, known);
                cut |= cut_decided_branches(reject, exprs, known);
            }
            Statement::Loop { body, continuing, .. } => {
                cut |= cut_decided_branches(body, exprs, known);
                cut |= cut_decided_branches(continuing, exprs, known);
            }
            Statement::Switch { cases, .. } => {
                for case in cases {
                    cut |= cut_decided_branches(&mut case.body, exprs, known);
                }
            }
            _ => {}
        }
        let ends = always_leaves(&statement);
        block.push(statement, span);
        if ends {
            // What follows a return never runs (`if (!TREE) { return color; }`
            // leaves the rest of the tree's code behind its cut branch).
            break;
        }
    }
    cut
}

/// Whether `statement` leaves the block it is in on every path through it: it returns, or
/// continues or breaks out of the loop or switch around it.
fn always_leaves(statement: &Statement) -> bool {
    match statement {
        Statement::Return { .. } | Statement::Kill | Statement::Break | Statement::Continue => true,
        Statement::Block(inner) => inner.last().is_some_and(always_leaves),
        Statement::If { accept, reject, .. } => {
            accept.last().is_some_and(always_leaves) && reject.last().is_some_and(always_leaves)
        }
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn function_names(module: &Module) -> Vec<String> {
        module.functions.iter().filter_map(|(_, f)| f.name.clone()).collect()
    }

    const TOY: &str = "
        override FEATURE: bool = false;
        override DEPTH: u32 = 0u;
        @group(0) @binding(0) var<storage, read_write> out: array<u32>;
        fn costly(x: u32) -> u32 { return x * 7u; }
        fn also_costly(x: u32) -> u32 { return x + 3u; }
        fn kept(x: u32) -> u32 { return x - 1u; }
        @compute @workgroup_size(1) fn main(@builtin(global_invocation_id) id: vec3<u32>) {
            var v = id.x;
            if (FEATURE && v > 2u) { v = costly(v); }
            if (DEPTH == 0u) { v = kept(v); } else { v = also_costly(v); }
            if (v > 5u) { v = kept(v); }
            out[id.x] = v;
        }
        @compute @workgroup_size(1) fn other(@builtin(global_invocation_id) id: vec3<u32>) { out[id.x] = costly(id.x); }";

    /// A branch the constants decide is cut with what only it calls; a branch they do not
    /// decide stays; the other entry point goes.
    #[test]
    fn decided_branches_and_what_only_they_call_are_cut() {
        let module = parse(TOY);
        let off = specialise(&module, &[("FEATURE", 0.0), ("DEPTH", 0.0)], "main");
        assert_eq!(function_names(&off), ["kept"]);
        assert_eq!(off.entry_points.len(), 1);
        assert!(off.overrides.is_empty());
        let on = specialise(&module, &[("FEATURE", 1.0), ("DEPTH", 2.0)], "main");
        assert_eq!(function_names(&on), ["costly", "also_costly", "kept"]);
    }

    /// What follows a `continue` that the constants leave unconditional is cut, with what
    /// only it calls; with the branch undecided, it stays.
    #[test]
    fn what_follows_a_decided_continue_is_cut() {
        let module = parse(
            "
            override FAST: bool = false;
            @group(0) @binding(0) var<storage, read_write> out: array<u32>;
            fn fast(x: u32) -> u32 { return x + 1u; }
            fn general(x: u32) -> u32 { return x * 3u; }
            @compute @workgroup_size(1) fn main(@builtin(global_invocation_id) id: vec3<u32>) {
                var v = id.x;
                for (var k = 0u; k < 4u; k++) {
                    if (FAST) { v = fast(v); continue; }
                    v = general(v);
                }
                out[id.x] = v;
            }",
        );
        assert_eq!(function_names(&specialise(&module, &[("FAST", 1.0)], "main")), ["fast"]);
        assert_eq!(function_names(&specialise(&module, &[("FAST", 0.0)], "main")), ["general"]);
    }

    /// The kernel's features reach the driver only when switched on: solid textures (Perlin's
    /// noise), ray trees and the grid's walk.
    #[test]
    fn the_kernel_keeps_only_the_features_switched_on() {
        let module = super::super::shader::module();
        // Spheres shaded by one light into a colour image; every other switch off.
        let on = ["HAS_SPHERES", "WANT_COLOR", "NUM_LIGHTS", "PIXEL_WORDS"];
        let all_off: Vec<(&str, f64)> = module
            .overrides
            .iter()
            .filter_map(|(_, o)| o.name.as_deref())
            .map(|name| (name, if on.contains(&name) { 1.0 } else { 0.0 }))
            .collect();
        let with = |name: &str| -> Vec<(&str, f64)> {
            all_off.iter().map(|&(n, v)| (n, if n == name { 1.0 } else { v })).collect()
        };
        let has = |m: &Module, f: &str| function_names(m).iter().any(|n| n == f);
        let plain = specialise(module, &all_off, "main");
        for feature_function in ["improved_noise", "pop_pending", "grid_closest"] {
            assert!(!has(&plain, feature_function), "{feature_function} in a kernel without its feature");
        }
        assert!(has(&specialise(module, &with("TEXTURES"), "main"), "improved_noise"));
        assert!(has(&specialise(module, &with("TREE"), "main"), "pop_pending"));
        assert!(has(&specialise(module, &with("USE_GRID"), "main"), "grid_closest"));
        assert!(function_names(&plain).len() * 3 < function_names(module).len(), "{:?}", function_names(&plain));
    }

    /// Only `main_bins_shared` uses subgroups: every other kernel, cut down, validates
    /// without them, so devices that offer none (or browsers) still run it.
    #[test]
    fn only_the_shared_walk_needs_subgroups() {
        let module = super::super::shader::module();
        let constants: Vec<(&str, f64)> = module
            .overrides
            .iter()
            .filter_map(|(_, o)| o.name.as_deref())
            .map(|name| (name, if name == "USE_BINS" || name == "HAS_TRIANGLES" { 1.0 } else { 0.0 }))
            .collect();
        let without =
            || naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default());
        for entry in &module.entry_points {
            let cut = specialise(module, &constants, &entry.name);
            let valid = without().validate(&cut);
            assert_eq!(valid.is_ok(), entry.name != "main_bins_shared", "{}: {:?}", entry.name, valid.err());
        }
    }
}
