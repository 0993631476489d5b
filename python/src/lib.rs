//! `hdrflow._hdrflow`: the Python extension over the hdrflow library (no second implementation:
//! pipelines load, validate, run and cache exactly as on the command line).
//!
//! The public Python API is `python/hdrflow/__init__.py`; this module gives it five functions:
//! - `run_pipeline`: load (a file or RON text) with `--set` overrides, supply NumPy arrays in place
//!   of nodes (`Pipeline::provide`), run with the GIL released, and convert the targets' values;
//! - `run_batch`: `hdrflow batch` (`crate::batch`) over a pipeline file, the GIL released;
//! - `ops` and `value_types`: the registry's description;
//! - `register_operator`: a Python function as an operator (`OpSpec` built at run time: fields
//!   declared from Python with `OpSpec::field_spec`, an untyped evaluation, `OpSpec::eval_raw`,
//!   that takes the GIL).
//!
//! Every function takes its arguments by keyword (all but the first keyword-only, so that a call
//! cannot pass them in the wrong order); `hdrflow/_hdrflow.pyi` is the module's type stub.
//!
//! Values come back as NumPy arrays without copying where the engine holds the only reference:
//! an image's `Vec<f32>` is moved into the array (`PyArray::from_owned_array`).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use hdrflow::engine::cache::store::DEFAULT_LIMIT_BYTES;
use hdrflow::engine::cache::{CacheStore, PersistPolicy};
use hdrflow::engine::error::PipelineErrors;
use hdrflow::engine::op::{check_pixels, OpContext, OpError, OpSpec, OutputType, Outputs};
use hdrflow::engine::params::{Arity, FieldKind, FieldSpec, ParamValue};
use hdrflow::engine::scheduler::{self, RunOptions, Silent};
use hdrflow::engine::value::{FileBlob, Value, ValueType};
use hdrflow::values::image::default_names;
use hdrflow::values::{Curves, Distribution2D, Image, Metrics, SampleSet, ShCoefficients};
use hdrflow::{Override, Pipeline, Registry};
use numpy::ndarray::{Array2, Array3};
use numpy::{PyArray1, PyArray2, PyArray3, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

pyo3::create_exception!(
    hdrflow,
    PipelineError,
    PyValueError,
    "A pipeline that does not validate; the message has one `file:line:col: node \"x\": message` line per problem, `errors` the same as dicts."
);
pyo3::create_exception!(
    hdrflow,
    RunError,
    PyRuntimeError,
    "A run that failed (an operator's error, an output folder that cannot be written, an unknown target)."
);

/// The process-wide registry: the built-in operators plus those registered from Python.
static REGISTRY: Mutex<Option<Registry>> = Mutex::new(None);

fn with_registry<R>(f: impl FnOnce(&mut Registry) -> R) -> R {
    let mut guard = REGISTRY.lock().unwrap_or_else(|e| e.into_inner());
    f(guard.get_or_insert_with(hdrflow::builtin_registry))
}

/// Names of the operators hdrflow itself provides (a Python operator may not replace them).
fn builtin_names() -> &'static BTreeSet<&'static str> {
    static NAMES: std::sync::OnceLock<BTreeSet<&'static str>> = std::sync::OnceLock::new();
    NAMES.get_or_init(|| hdrflow::builtin_registry().names().into_iter().collect())
}

fn pipeline_error(py: Python<'_>, errors: &PipelineErrors) -> PyErr {
    let err = PipelineError::new_err(errors.to_string());
    let list = PyList::empty(py);
    for e in &errors.0 {
        let d = PyDict::new(py);
        let _ = d.set_item("source", &e.source);
        let _ = d.set_item("line", e.pos.map(|p| p.line));
        let _ = d.set_item("col", e.pos.map(|p| p.col));
        let _ = d.set_item("node", e.node.as_deref());
        let _ = d.set_item("message", &e.message);
        let _ = d.set_item("text", e.to_string());
        let _ = list.append(d);
    }
    let _ = err.value(py).setattr("errors", list);
    err
}

/// The targets when the caller names none: what the command line would run (every Save node
/// and every node nothing consumes) plus the values the Save nodes write, so that everything
/// the command line writes as a file comes back as an array. Without an output folder, the
/// file-writing nodes themselves are left out: nothing is written.
fn default_targets(p: &Pipeline, with_files: bool) -> Vec<String> {
    let mut set = BTreeSet::new();
    for i in p.default_targets() {
        let node = &p.nodes[i];
        if node.writes_file() {
            set.extend(node.sources().map(|s| s.node));
            if with_files {
                set.insert(i);
            }
        } else {
            set.insert(i);
        }
    }
    set.into_iter().map(|i| p.nodes[i].name.clone()).collect()
}

/// A C-contiguous float32 (H, W, C) array as an image with the conventional channel names
/// (`Y`, `Y A`, `R G B`, `R G B A`, `C0 ...`). The data is copied once into the engine's buffer.
fn array_to_image(a: &PyReadonlyArray3<'_, f32>) -> PyResult<Image> {
    let [h, w, c]: [usize; 3] = a.shape().try_into().expect("a 3-D array");
    if h == 0 || w == 0 || c == 0 {
        return Err(PyValueError::new_err(format!("an image array needs H, W, C >= 1, not ({h}, {w}, {c})")));
    }
    check_pixels(w as u64, h as u64).map_err(PyValueError::new_err)?;
    let data = match a.as_slice() {
        Ok(s) => s.to_vec(),
        Err(_) => a.as_array().iter().copied().collect(),
    };
    Ok(Image::with_names(w, h, default_names(c), data))
}

fn f64_array<'py>(py: Python<'py>, v: Vec<f64>) -> Bound<'py, PyAny> {
    PyArray1::from_vec(py, v).into_any()
}

/// A value as a Python object (see the book's Python page, docs/src/guides/python.md, for the
/// mapping). An image is moved into its NumPy array when nothing else holds it (no copy), else
/// copied once.
fn value_to_py<'py>(py: Python<'py>, value: Value, out: Option<&Path>) -> PyResult<Bound<'py, PyAny>> {
    if value.get::<Image>().is_some() {
        let img = value.take::<Image>().expect("checked to be an image");
        let arr = Array3::from_shape_vec((img.height, img.width, img.channels), img.data)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        return Ok(PyArray3::from_owned_array(py, arr).into_any());
    }
    let d = PyDict::new(py);
    if let Some(m) = value.get::<Metrics>() {
        for (k, v) in &m.fields {
            d.set_item(k, v)?;
        }
    } else if let Some(c) = value.get::<Curves>() {
        d.set_item("title", &c.title)?;
        d.set_item("x_name", &c.x_name)?;
        d.set_item("x_label", &c.x_label)?;
        d.set_item("y_label", &c.y_label)?;
        d.set_item("x", f64_array(py, c.x.clone()))?;
        let series = PyDict::new(py);
        for (k, v) in &c.series {
            series.set_item(k, f64_array(py, v.clone()))?;
        }
        d.set_item("series", series)?;
        let scalars = PyDict::new(py);
        for (k, v) in &c.scalars {
            scalars.set_item(k, *v)?;
        }
        d.set_item("scalars", scalars)?;
        d.set_item("markers", c.markers.clone())?;
    } else if let Some(s) = value.get::<SampleSet>() {
        d.set_item("width", s.width)?;
        d.set_item("height", s.height)?;
        d.set_item("luminance_integral", s.luminance_integral)?;
        let col = |f: &dyn Fn(&hdrflow::values::Sample) -> f32| s.samples.iter().map(f).collect::<Vec<f32>>();
        d.set_item("x", PyArray1::from_vec(py, s.samples.iter().map(|p| p.x).collect::<Vec<u32>>()))?;
        d.set_item("y", PyArray1::from_vec(py, s.samples.iter().map(|p| p.y).collect::<Vec<u32>>()))?;
        d.set_item("theta", PyArray1::from_vec(py, col(&|p| p.theta)))?;
        d.set_item("phi", PyArray1::from_vec(py, col(&|p| p.phi)))?;
        let dirs = Array2::from_shape_vec((s.samples.len(), 3), s.samples.iter().flat_map(|p| p.dir).collect())
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        d.set_item("dir", PyArray2::from_owned_array(py, dirs))?;
        d.set_item("pdf", PyArray1::from_vec(py, col(&|p| p.pdf)))?;
    } else if let Some(dist) = value.get::<Distribution2D>() {
        d.set_item("width", dist.width())?;
        d.set_item("height", dist.height())?;
        d.set_item("sin_theta", dist.sin_theta())?;
        // The weights are not stored (issue 14): derived from the conditional CDFs on demand.
        let func = Array2::from_shape_vec((dist.height(), dist.width()), dist.weights())
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        d.set_item("func", PyArray2::from_owned_array(py, func))?;
        let cond = Array2::from_shape_vec((dist.height(), dist.width() + 1), dist.conditional_cdf().to_vec())
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        d.set_item("conditional_cdf", PyArray2::from_owned_array(py, cond))?;
        d.set_item("row_sums", f64_array(py, dist.row_sums().to_vec()))?;
        d.set_item("marginal_cdf", f64_array(py, dist.marginal_cdf().to_vec()))?;
        d.set_item("total", dist.total())?;
        d.set_item("luminance_integral", dist.luminance_integral())?;
        d.set_item("carries_light", dist.carries_light())?;
    } else if let Some(sh) = value.get::<ShCoefficients>() {
        d.set_item("order", sh.order)?;
        d.set_item("frame", format!("{:?}", sh.frame))?;
        let rgb = Array2::from_shape_vec((sh.rgb.len(), 3), sh.rgb.iter().flatten().copied().collect())
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        d.set_item("rgb", PyArray2::from_owned_array(py, rgb))?;
    } else if let Some(f) = value.get::<FileBlob>() {
        // A Save node's file: the path it was written to (or found unchanged at).
        let dir = out.expect("file values exist only when an output folder is given");
        return Ok(dir.join(&f.rel_path).to_string_lossy().into_owned().into_pyobject(py)?.into_any());
    } else {
        // A value type this module does not know (a user's own): its type and its text.
        d.set_item("type", value.value_type().name())?;
        d.set_item("summary", value.summary())?;
        d.set_item("display", value.display())?;
    }
    Ok(d.into_any())
}

/// Loads, provides, runs and converts; see `hdrflow.run` in `__init__.py` for the arguments.
/// Returns (values by `node` / `node.port`, the report as JSON text, channel names by key).
/// Every argument but the pipeline is keyword-only, with `hdrflow.run`'s defaults (the stub is
/// `hdrflow/_hdrflow.pyi`).
#[pyfunction]
#[pyo3(signature = (
    pipeline,
    *,
    is_path = false,
    overrides = Vec::new(),
    targets = None,
    out = None,
    cache_dir = None,
    no_cache = false,
    jobs = None,
    inputs = Vec::new(),
))]
#[allow(clippy::too_many_arguments)]
fn run_pipeline<'py>(
    py: Python<'py>,
    pipeline: String,
    is_path: bool,
    overrides: Vec<String>,
    targets: Option<Vec<String>>,
    out: Option<PathBuf>,
    cache_dir: Option<PathBuf>,
    no_cache: bool,
    jobs: Option<usize>,
    inputs: Vec<(String, PyReadonlyArray3<'py, f32>)>,
) -> PyResult<(Bound<'py, PyDict>, String, Bound<'py, PyDict>)> {
    let mut parsed = Vec::new();
    for s in &overrides {
        parsed.push(Override::parse(s).map_err(PipelineError::new_err)?);
    }
    let registry = with_registry(|r| r.clone());
    // The nodes given in `inputs` are not run: their files need not exist.
    let provided: Vec<&str> = inputs.iter().map(|(name, _)| name.as_str()).collect();
    let loaded = if is_path {
        py.detach(|| Pipeline::load_providing(Path::new(&pipeline), &registry, &parsed, &provided))
    } else {
        py.detach(|| Pipeline::parse_providing(&pipeline, "<string>", Path::new(""), &registry, &parsed, &provided))
    };
    let mut p = loaded.map_err(|e| pipeline_error(py, &e))?;
    for (name, array) in &inputs {
        let image = array_to_image(array)?;
        p.provide(name, Value::new(image)).map_err(|e| PyValueError::new_err(format!("inputs[{name:?}]: {e}")))?;
    }
    let targets = match targets {
        Some(t) => {
            if out.is_none() {
                if let Some(n) = t.iter().filter_map(|t| p.index_of(t)).find(|&i| p.nodes[i].writes_file()) {
                    return Err(PyValueError::new_err(format!(
                        "target {:?} writes a file: pass out= (a folder) to run it",
                        p.nodes[n].name
                    )));
                }
            }
            t
        }
        None => default_targets(&p, out.is_some()),
    };
    let cache = (!no_cache).then(|| {
        CacheStore::new(cache_dir.unwrap_or_else(CacheStore::default_dir), DEFAULT_LIMIT_BYTES)
            .with_policy(PersistPolicy::Auto)
    });
    // Without an output folder nothing writes a file (see `default_targets`); this folder is
    // never created.
    let out_dir = out.clone().unwrap_or_else(|| std::env::temp_dir().join("hdrflow-no-output"));
    let options = RunOptions { targets, out_dir, cache, jobs: jobs.filter(|&j| j > 0), observer: &Silent };
    let outcome = py.detach(|| {
        let outcome = scheduler::run(&p, &options);
        // As the command line does: prune the folder to its size limit, sparing live runs.
        if let Some(cache) = options.cache.as_ref().filter(|c| c.root().is_dir()) {
            let _ = cache.evict();
        }
        outcome
    });
    drop(p); // its provided values: the arrays' copies
    let outcome = outcome.map_err(|e| RunError::new_err(e.to_string()))?;
    let report = serde_json::to_string(&outcome.report).expect("the report serialises");
    let values = PyDict::new(py);
    let channels = PyDict::new(py);
    for (key, value) in outcome.values {
        if let Some(img) = value.get::<Image>() {
            channels.set_item(&key, img.names.clone())?;
        }
        values.set_item(&key, value_to_py(py, value, out.as_deref())?)?;
    }
    Ok((values, report, channels))
}

fn param_to_py<'py>(py: Python<'py>, v: &ParamValue) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        ParamValue::Float(x) => x.into_pyobject(py)?.into_any(),
        ParamValue::Int(x) => x.into_pyobject(py)?.into_any(),
        ParamValue::Bool(x) => x.into_pyobject(py)?.to_owned().into_any(),
        ParamValue::Text(s) | ParamValue::Choice(s) => s.into_pyobject(py)?.into_any(),
        ParamValue::TextList(v) => v.clone().into_pyobject(py)?.into_any(),
        ParamValue::Tuple(v) => pyo3::types::PyTuple::new(py, v)?.into_any(),
    })
}

/// Describes every operator of the process-wide registry (`hdrflow.ops()`).
#[pyfunction]
fn ops(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let registry = with_registry(|r| r.clone());
    let list = PyList::empty(py);
    for spec in registry.all() {
        let d = PyDict::new(py);
        d.set_item("name", spec.name)?;
        d.set_item("category", spec.category)?;
        d.set_item("version", spec.version)?;
        d.set_item("doc", spec.doc)?;
        d.set_item("persist", format!("{:?}", spec.persist))?;
        let outputs = PyList::empty(py);
        for port in &spec.outputs {
            let o = PyDict::new(py);
            o.set_item("name", port.name)?;
            o.set_item("type", port.ty.describe())?;
            o.set_item("doc", port.doc)?;
            outputs.append(o)?;
        }
        if let Some(open) = &spec.open_ports {
            let o = PyDict::new(py);
            o.set_item("name", "*")?;
            o.set_item("type", open.ty.name())?;
            o.set_item("doc", open.doc)?;
            outputs.append(o)?;
        }
        d.set_item("outputs", outputs)?;
        let fields = PyList::empty(py);
        for f in &spec.fields {
            let fd = PyDict::new(py);
            fd.set_item("name", f.name)?;
            fd.set_item("kind", f.kind.describe())?;
            fd.set_item("input", f.is_input())?;
            match &f.default {
                Some(v) => fd.set_item("default", param_to_py(py, v)?)?,
                None => fd.set_item("default", py.None())?,
            }
            fd.set_item("required", f.describe_default() == "required")?;
            fd.set_item("doc", &f.doc)?;
            fields.append(fd)?;
        }
        d.set_item("fields", fields)?;
        list.append(d)?;
    }
    Ok(list)
}

/// The registry's value type names (`image`, `scalar field`, ...).
#[pyfunction]
fn value_types() -> Vec<&'static str> {
    with_registry(|r| r.value_types().into_iter().map(|t| t.name()).collect())
}

/// A value type by name; `scalar_field` is accepted for `scalar field`.
fn find_type(r: &Registry, name: &str) -> Option<ValueType> {
    r.value_type(name).or_else(|| r.value_type(&name.replace('_', " ")))
}

/// Operator and field names live as long as the process: a spec's names are `&'static str`.
/// Registering is rare (once per decorated function), so the few leaked bytes are bounded by
/// the number of registrations.
fn leak(s: &str) -> &'static str {
    Box::leak(s.to_string().into_boxed_str())
}

/// Registers a Python function as an operator. `fields`: (name, kind, default, doc) with kind
/// `input:<value type>`, `float`, `int`, `bool` or `str`. The function is called with every
/// field as a keyword argument (inputs as float32 (H, W, C) arrays) and must return a float32
/// C-contiguous (H, W, C) array (the Python wrapper makes sure).
#[pyfunction]
#[pyo3(signature = (name, *, category, doc, version, fields, output, func, source))]
#[allow(clippy::too_many_arguments)]
fn register_operator(
    name: &str,
    category: &str,
    doc: &str,
    version: u32,
    fields: Vec<(String, String, Option<Bound<'_, PyAny>>, String)>,
    output: &str,
    func: Py<PyAny>,
    source: &str,
) -> PyResult<()> {
    if builtin_names().contains(name) {
        return Err(PyValueError::new_err(format!("{name:?} is a built-in operator; choose another name")));
    }
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(PyValueError::new_err(format!("operator name {name:?}: use letters, digits and _ only")));
    }
    let registry = with_registry(|r| r.clone());
    let out_ty =
        find_type(&registry, output).filter(|t| t.name() == "image" || t.name() == "scalar field").ok_or_else(
            || PyValueError::new_err(format!("output {output:?}: a Python operator returns `image` or `scalar_field`")),
        )?;
    let op_name = leak(name);
    let mut spec = OpSpec::new(op_name, leak(category), version, leak(doc));
    // The function's source and its declared version are in every key (the version is
    // `spec.version`): editing the function recomputes, as a Rust operator's code hash does. So
    // is the glue its values pass through (this file, and the wrapper in `hdrflow/__init__.py`
    // that calls it), which the library's engine salt does not cover.
    let mut code = blake3::Hasher::new();
    for part in [include_str!("lib.rs"), include_str!("../hdrflow/__init__.py"), source] {
        code.update(&(part.len() as u64).to_le_bytes());
        code.update(part.as_bytes());
    }
    spec.code_hash = *code.finalize().as_bytes();
    let mut seen = BTreeSet::new();
    for (field, kind, default, fdoc) in fields {
        if !seen.insert(field.clone()) {
            return Err(PyValueError::new_err(format!("field {field:?} is declared twice")));
        }
        let (kind, default) = match kind.as_str() {
            k if k.starts_with("input:") => {
                let tname = &k["input:".len()..];
                let ty = find_type(&registry, tname)
                    .filter(|t| t.name() != "file")
                    .ok_or_else(|| PyValueError::new_err(format!("field {field:?}: unknown value type {tname:?}")))?;
                (FieldKind::Input { types: vec![ty], arity: Arity::One }, None)
            }
            "float" => (
                FieldKind::Float { min: f64::MIN, max: f64::MAX },
                default.map(|d| d.extract::<f64>().map(ParamValue::Float)).transpose()?,
            ),
            "int" => (
                FieldKind::Int { min: i64::MIN, max: i64::MAX },
                default.map(|d| d.extract::<i64>().map(ParamValue::Int)).transpose()?,
            ),
            "bool" => (FieldKind::Bool, default.map(|d| d.extract::<bool>().map(ParamValue::Bool)).transpose()?),
            "str" => (FieldKind::Text, default.map(|d| d.extract::<String>().map(ParamValue::Text)).transpose()?),
            other => return Err(PyValueError::new_err(format!("field {field:?}: unknown kind {other:?}"))),
        };
        spec = spec.field_spec(FieldSpec { name: leak(&field), kind, default, optional: false, doc: fdoc });
    }
    spec = spec.output("out", OutputType::Fixed(out_ty), "the function's result");
    let func = Arc::new(func);
    spec = spec.eval_raw(Arc::new(move |ctx: &mut OpContext| eval_python(op_name, &func, ctx)));
    // A Python operator declared again (a notebook cell run twice) replaces the first; a
    // built-in's name is refused.
    if hdrflow::builtin_registry().get(op_name).is_some() {
        return Err(PyValueError::new_err(format!(
            "{op_name:?} is the name of a built-in operator: choose another name"
        )));
    }
    with_registry(|r| {
        r.replace(spec);
    });
    Ok(())
}

/// A Python operator's evaluation: takes the GIL, hands the inputs over as arrays (moved, not
/// copied, when this node is their last consumer) and the parameters as Python values, calls
/// the function and wraps the returned array as an image.
fn eval_python(op: &str, func: &Py<PyAny>, ctx: &mut OpContext) -> Result<Outputs, OpError> {
    let inputs = std::mem::take(&mut ctx.inputs);
    Python::attach(|py| {
        let py_err = |e: PyErr| {
            let tb = e.traceback(py).and_then(|t| t.format().ok()).unwrap_or_default();
            OpError::Invalid(format!("the Python operator {op} raised {e}\n{tb}").trim_end().to_string())
        };
        let kwargs = PyDict::new(py);
        for (field, values) in inputs {
            for v in values {
                kwargs.set_item(field, value_to_py(py, v, None).map_err(py_err)?).map_err(py_err)?;
            }
        }
        for (name, v) in &ctx.params.values {
            kwargs.set_item(*name, param_to_py(py, v).map_err(py_err)?).map_err(py_err)?;
        }
        let result = func.bind(py).call((), Some(&kwargs)).map_err(py_err)?;
        let array = result.extract::<PyReadonlyArray3<f32>>().map_err(|e| {
            OpError::Invalid(format!("the Python operator {op} returned something other than an (H, W, C) array: {e}"))
        })?;
        let image = array_to_image(&array).map_err(py_err)?;
        Ok(Outputs::from(Value::new(image)))
    })
}

/// A batch observer that says nothing (the library never prints).
struct QuietBatch;
impl hdrflow::batch::BatchObserver for QuietBatch {}

/// `hdrflow batch` over a pipeline file: `axes` are (`NODE.FIELD=GLOB_OR_LIST` or `NODE.FIELD`,
/// explicit values or None, `over`). Returns the report rows as JSON text (`--report`'s rows).
/// Every argument but the graph is keyword-only, with `hdrflow.batch`'s defaults.
#[pyfunction]
#[pyo3(signature = (
    graph,
    *,
    axes = Vec::new(),
    zip = false,
    item_dir = None,
    out = PathBuf::from("out"),
    cache_dir = None,
    jobs = None,
    keep_going = false,
))]
#[allow(clippy::too_many_arguments)]
fn run_batch(
    py: Python<'_>,
    graph: PathBuf,
    axes: Vec<(String, Option<Vec<String>>, bool)>,
    zip: bool,
    item_dir: Option<String>,
    out: PathBuf,
    cache_dir: Option<PathBuf>,
    jobs: Option<usize>,
    keep_going: bool,
) -> PyResult<String> {
    use hdrflow::batch::{self, Axis, BatchOptions};
    let mut parsed = Vec::new();
    for (spec, values, over) in axes {
        let axis = match values {
            None => Axis::parse(&spec, over).map_err(PipelineError::new_err)?,
            Some(values) => {
                let o = Override::parse(&format!("{spec}=")).map_err(PipelineError::new_err)?;
                Axis { node: o.node, field: o.field, values, over }
            }
        };
        parsed.push(axis);
    }
    let items = batch::items(&parsed, zip, item_dir.as_deref()).map_err(PyValueError::new_err)?;
    let registry = with_registry(|r| r.clone());
    let pipelines = py
        .detach(|| batch::validate(&registry, &graph, &items))
        .map_err(|errors| PipelineError::new_err(errors.join("\n")))?;
    scheduler::check_output_dir(&out).map_err(|e| RunError::new_err(e.to_string()))?;
    let cache = CacheStore::new(cache_dir.unwrap_or_else(CacheStore::default_dir), DEFAULT_LIMIT_BYTES)
        .with_policy(PersistPolicy::Auto);
    let options = BatchOptions {
        out_dir: out,
        cache,
        cache_limit_bytes: DEFAULT_LIMIT_BYTES,
        jobs: jobs.filter(|&j| j > 0),
        keep_going,
        observer: &QuietBatch,
        cancel: None,
    };
    let outcome = py.detach(|| batch::run(&items, &pipelines, &options));
    Ok(batch::json_rows(&outcome.rows).to_string())
}

/// The `hdrflow` command line over this process's registry (the built-ins plus the operators
/// registered from Python): what `hdrflow run --python FILE ...` hands over to. `args` starts
/// with the program name. The GIL is released while it runs, so that Python operators can
/// take it on the worker threads. Returns the exit code.
#[pyfunction]
#[pyo3(signature = (args))]
fn cli_main(py: Python<'_>, args: Vec<String>) -> u8 {
    let registry = with_registry(|r| r.clone());
    let code = py.detach(|| hdrflow::cli::main_from(registry, args));
    // `ExitCode` has no accessor, but compares equal to the code it was made from.
    (0..=255u8).find(|&k| code == std::process::ExitCode::from(k)).unwrap_or(1)
}

#[pymodule]
fn _hdrflow(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // A bad HDRFLOW_CPU fails the import, before any work (the kernels would ignore it).
    hdrflow::cpu::init().map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    let py = m.py();
    m.add("PipelineError", py.get_type::<PipelineError>())?;
    m.add("RunError", py.get_type::<RunError>())?;
    m.add_function(wrap_pyfunction!(run_pipeline, m)?)?;
    m.add_function(wrap_pyfunction!(cli_main, m)?)?;
    m.add_function(wrap_pyfunction!(run_batch, m)?)?;
    m.add_function(wrap_pyfunction!(ops, m)?)?;
    m.add_function(wrap_pyfunction!(value_types, m)?)?;
    m.add_function(wrap_pyfunction!(register_operator, m)?)?;
    Ok(())
}
