// The Python module's native part, `rvoronoi._rvoronoi`: the engine façade (rv/job.hpp) and the
// option table (rv/options.hpp) as Python sees them. The package around it (python/rvoronoi/)
// turns seeds into files, arrays into an xarray.Dataset and chunks into a Dask graph; every rule
// (options, checks, computation, messages) is the façade's.
//
// What crosses: options as JSON text (keyword -> value, checked by the option table under the
// keyword's name), seed paths, a window; back come NumPy arrays that own the engine's buffers
// (no copy), the report as JSON text, and the grid. rv::Error becomes the exception class the
// error table names for its kind (rvoronoi.InvalidArgument, ...), with the same message.
// The GIL is released while the façade reads and computes.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "rv/engine/outputs.hpp"
#include "rv/error_map.hpp"
#include "rv/field/error.hpp"
#include "rv/job.hpp"
#include "rv/json_text.hpp"
#include "rv/options.hpp"
#include "rv/seed_description.hpp"
#include "rv/session.hpp"
#include "rv/version.hpp"

namespace py = pybind11;

namespace {

// Options the module does not take as keywords: its results are arrays and deliverables it
// returns (not files it is told to write), and these steer files or runs it does not make.
const std::set<std::string, std::less<>> kNotKeywords = {
    "ownership", "distance", "nearest-feature", "report",  "cog",           "compression", "boundaries",   "tripoints",
    "limits",    "regions",  "turning-points",  "changes", "margin-raster", "preview",     "no-edit-base", "strip-rows",
    "base",      "via"};

bool is_keyword(const rv::OptionSpec& o) { return !o.flag.empty() && !kNotKeywords.contains(o.flag); }

// What rvoronoi.run takes besides (it writes files): how they are written.
const std::set<std::string, std::less<>> kFileKeywords = {"compression", "cog"};
bool is_run_keyword(const rv::OptionSpec& o) { return is_keyword(o) || kFileKeywords.contains(o.flag); }

const char* type_name(rv::OptionType t) {
  switch (t) {
    case rv::OptionType::positive_number:
    case rv::OptionType::nonnegative_number:
    case rv::OptionType::number:
      return "number";
    case rv::OptionType::count:
      return "integer";
    case rv::OptionType::text:
      return "text";
    case rv::OptionType::choice:
      return "choice";
    case rv::OptionType::flag:
      return "bool";
    case rv::OptionType::extent:
      return "extent";
    case rv::OptionType::distance_list:
      return "distances";
    case rv::OptionType::file:
    case rv::OptionType::layers:
      return "path";
    case rv::OptionType::length:
      return "length";
  }
  return "text";
}

// The exception classes, one per error kind, made from the error table at import. Never
// destroyed: the interpreter may be gone by the time static objects are.
std::vector<py::object>& error_classes() {
  static auto* classes = new std::vector<py::object>();
  return *classes;
}

// The JobSpec of seed paths and keyword options (JSON text: keyword -> value).
rv::JobSpec make_spec(const std::vector<std::string>& seeds, const std::string& options_json, bool files = false) {
  rv::JobSpec spec;
  spec.seeds.paths = seeds;
  nlohmann::json options;
  try {
    options = nlohmann::json::parse(options_json);
  } catch (const nlohmann::json::exception& e) {
    throw rv::Error(rv::ErrorKind::internal, std::string("options are not JSON: ") + e.what());
  }
  if (!options.is_object()) throw rv::Error(rv::ErrorKind::internal, "options must be a JSON object");
  for (const auto& [key, value] : options.items()) {
    if (value.is_null()) continue;  // None: the option's default
    const rv::OptionSpec* o = nullptr;
    for (const rv::OptionSpec& c : rv::job_options())
      if ((files ? is_run_keyword(c) : is_keyword(c)) && rv::option_keyword(c) == key) o = &c;
    if (!o)
      throw rv::Error(rv::ErrorKind::invalid_argument,
                      key + (files ? ": not an option of rvoronoi.run" : ": not an option of rvoronoi.compute"));
    o->apply(spec, rv::parse_json_value(*o, value, key));
  }
  return spec;
}

std::optional<rv::Window> to_window(const std::optional<std::vector<int64_t>>& w) {
  if (!w) return std::nullopt;
  if (w->size() != 4) throw rv::Error(rv::ErrorKind::invalid_argument, "window: (row0, col0, rows, cols)");
  return rv::Window{(*w)[1], (*w)[0], (*w)[3], (*w)[2]};
}

// A raster's cells as a 2-D NumPy array that owns them (the raster moves into its capsule).
template <class T>
py::array_t<T> to_numpy(rv::Raster<T>&& raster) {
  auto* owned = new rv::Raster<T>(std::move(raster));
  py::capsule free_it(owned, [](void* p) { delete static_cast<rv::Raster<T>*>(p); });
  const auto rows = static_cast<py::ssize_t>(owned->height());
  const auto cols = static_cast<py::ssize_t>(owned->width());
  return py::array_t<T>({rows, cols}, {cols * static_cast<py::ssize_t>(sizeof(T)), static_cast<py::ssize_t>(sizeof(T))},
                        owned->data(), free_it);
}

py::dict grid_dict(const rv::GridSpec& g) {
  py::dict d;
  d["width"] = g.width;
  d["height"] = g.height;
  d["xmin"] = g.xmin;
  d["ymax"] = g.ymax;
  d["resolution"] = g.res;
  d["crs_wkt"] = g.crs;
  return d;
}

// A job read and planned once; its pieces computed from it (Job.run), from any thread.
class Job {
 public:
  // max_cells: the limit of the whole grid (JobLimits::max_cells), whatever the window. The
  // façade checks the cells it computes, a window's; a chunked call makes its grid of windows,
  // so the whole grid is checked here, before any chunk exists, as an unchunked call's is.
  Job(const std::vector<std::string>& seeds, const std::string& options_json,
      const std::optional<std::vector<int64_t>>& window, int64_t max_cells) {
    if (max_cells < 1)
      throw rv::Error(rv::ErrorKind::invalid_argument,
                      "max_cells: must be a positive number of cells, got " + std::to_string(max_cells));
    spec_ = make_spec(seeds, options_json);
    spec_.window = to_window(window);
    limits_.max_cells = max_cells;
    py::gil_scoped_release free;
    job_ = rv::prepare_job(spec_, limits_);
    const int64_t cells = job_.grid.cell_count();
    if (cells > limits_.max_cells)  // the message of the façade's own check (job.cpp)
      throw rv::Error(rv::ErrorKind::too_large, "the grid has " + std::to_string(cells) + " cells, over the limit of " +
                                                    std::to_string(limits_.max_cells));
    // The engine's preparation of the seeds (sites in the grid's frame, the index), shared by
    // every piece. Not with partial effect: that rule computes a second field from another seed
    // set (and is never cut into pieces).
    if (!job_.partial.any()) job_.compute.prepared = rv::prepare(job_.loaded.seeds, job_.grid, job_.compute);
  }

  py::dict grid() const { return grid_dict(job_.grid); }
  std::vector<std::string> owners() const { return job_.loaded.seeds.owner_labels(); }
  std::string unit() const { return job_.unit; }
  std::string metric() const { return job_.metric.kind == rv::MetricSpec::geodesic ? "geodesic" : "planar"; }

  // products: any of "ownership", "distance", "nearest_feature", "via"; outputs: deliverable name ->
  // file (boundaries, tripoints, limits, regions, turning_points; whole grid only); describe:
  // whether to assemble the report (a chunk's caller does not keep it).
  py::dict run(const std::optional<std::vector<int64_t>>& window, const std::vector<std::string>& products,
               const std::map<std::string, std::string>& outputs, bool describe) const {
    rv::JobSpec spec = spec_;
    spec.window = to_window(window);
    spec.outputs.describe = describe;
    for (const std::string& p : products) {
      if (p == "ownership")
        spec.outputs.in_memory.ownership = true;
      else if (p == "distance")
        spec.outputs.in_memory.distance = true;
      else if (p == "nearest_feature")
        spec.outputs.in_memory.nearest_feature = true;
      else if (p == "via")
        spec.outputs.in_memory.via = true;
      else
        throw rv::Error(rv::ErrorKind::invalid_argument,
                        "product '" + p + "': ownership, distance, nearest_feature or via");
    }
    rv::OutputRequest& out = spec.outputs;
    for (const auto& [name, path] : outputs) {
      if (name == "boundaries")
        out.boundaries = path;
      else if (name == "tripoints")
        out.tripoints = path;
      else if (name == "limits")
        out.limits = path;
      else if (name == "regions")
        out.regions = path;
      else if (name == "turning_points")
        out.turning_points = path;
      else
        throw rv::Error(rv::ErrorKind::invalid_argument,
                        "deliverable '" + name + "': boundaries, tripoints, limits, regions or turning_points");
    }
    rv::JobResult r;
    {
      py::gil_scoped_release free;
      r = rv::run_prepared(spec, job_, limits_);
    }
    py::dict d;
    if (describe) d["report"] = rv::json_text(r.report, 2);
    if (spec.outputs.in_memory.ownership) d["ownership"] = to_numpy(std::move(r.rasters.ownership));
    if (spec.outputs.in_memory.distance) d["distance"] = to_numpy(std::move(r.rasters.distance));
    if (spec.outputs.in_memory.nearest_feature) d["nearest_feature"] = to_numpy(std::move(r.rasters.nearest_feature));
    if (spec.outputs.in_memory.via) d["via"] = to_numpy(std::move(r.rasters.via));
    return d;
  }

 private:
  rv::JobSpec spec_;
  rv::JobLimits limits_;
  rv::PreparedJob job_;
};

// The files of a whole job, written as the CLI writes them (rvoronoi.run): `outputs` maps process
// output ids (ownership, distance, nearestFeature, report, boundaries, tripoints, limits, regions,
// margin, preview, turningPoints) to paths. `progress(stage, fraction)` is called as the job goes,
// and `cancelled()` with it: True stops the job (rv::Error cancelled, nothing partial left).
// Either may be None. Returns the report as JSON text. The GIL is released while the job runs
// and taken for each call back; an exception a call back raises stops the job and is raised here.
std::string run_files(const std::vector<std::string>& seeds, const std::string& options_json,
                      const std::map<std::string, std::string>& outputs, py::object progress, py::object cancelled,
                      int64_t max_cells) {
  rv::JobSpec spec = make_spec(seeds, options_json, true);
  rv::OutputRequest& out = spec.outputs;
  for (const auto& [id, path] : outputs) {
    std::string* target = id == "changes" ? nullptr : rv::output_path(out, id);
    if (target == nullptr) throw rv::Error(rv::ErrorKind::invalid_argument, "outputs: no output '" + id + "'");
    *target = path;
  }
  rv::JobLimits limits;
  limits.max_cells = max_cells;
  std::atomic<bool> cancel{false};
  std::mutex error_mutex;
  std::optional<py::error_already_set> raised;
  rv::JobHooks hooks;
  hooks.cancel = &cancel;
  hooks.progress = [&](const std::string& stage, double fraction) {
    py::gil_scoped_acquire gil;
    try {
      if (!progress.is_none()) progress(stage, fraction);
      if (!cancelled.is_none() && cancelled().cast<bool>()) cancel = true;
    } catch (py::error_already_set& e) {
      std::lock_guard lock(error_mutex);
      if (!raised) raised.emplace(std::move(e));
      cancel = true;
    }
  };
  rv::JobResult result;
  try {
    py::gil_scoped_release free;
    result = rv::run_job(spec, limits, hooks);
  } catch (const rv::Error&) {
    if (raised) throw std::move(*raised);
    throw;
  }
  return rv::json_text(result.report, 2);
}

// A live what-if session (rv/session.hpp) in this process: rvoronoi.Session's engine. Edits,
// answers and documents cross as JSON text; the field as arrays in the job's units.
class Session {
 public:
  // deliverables: names among boundaries, tripoints, limits, regions, turning_points.
  Session(const std::vector<std::string>& seeds, const std::string& options_json,
          const std::vector<std::string>& deliverables, int undo_depth, int64_t max_cells) {
    rv::JobSpec spec = make_spec(seeds, options_json);
    rv::OutputRequest& out = spec.outputs;
    for (const std::string& name : deliverables) {
      std::string* target = name == "turning_points" ? &out.turning_points : rv::output_path(out, name);
      if (target == nullptr || name == "ownership" || name == "distance" || name == "nearestFeature" ||
          name == "report" || name == "margin" || name == "preview" || name == "changes")
        throw rv::Error(
            rv::ErrorKind::invalid_argument,
            "deliverables: '" + name + "' is not one of boundaries, tripoints, limits, regions, turning_points");
      *target = name;
    }
    rv::SessionLimits limits;
    limits.undo_depth = undo_depth;
    rv::JobLimits job_limits;
    job_limits.max_cells = max_cells;
    py::gil_scoped_release free;
    session_ = rv::Session::create(spec, limits, job_limits);
  }
  std::string edit(const std::string& edits) {
    nlohmann::json e;
    try {
      e = nlohmann::json::parse(edits);
    } catch (const nlohmann::json::exception& x) {
      throw rv::Error(rv::ErrorKind::invalid_argument, std::string("edits are not JSON: ") + x.what());
    }
    py::gil_scoped_release free;
    return rv::json_text(session_->edit(e));
  }
  std::string undo() {
    py::gil_scoped_release free;
    return rv::json_text(session_->undo());
  }
  std::string redo() {
    py::gil_scoped_release free;
    return rv::json_text(session_->redo());
  }
  std::string info() const { return rv::json_text(session_->info()); }
  std::string features() const { return rv::json_text(session_->features()); }
  std::vector<std::string> deliverables() const { return session_->deliverables(); }
  std::string deliverable(const std::string& name) const { return session_->deliverable(name); }
  std::string line_ids() const { return rv::json_text(session_->line_ids()); }
  py::dict grid() const { return grid_dict(session_->grid()); }
  std::vector<std::string> owners() const { return session_->seeds().owner_labels(); }
  std::string unit() const { return session_->job().unit; }
  std::string metric() const { return session_->job().metric.kind == rv::MetricSpec::geodesic ? "geodesic" : "planar"; }
  // The field as the files hold it: owner codes, distances in the job's units, 1-based input
  // positions of the nearest feature.
  py::dict arrays() const {
    const rv::PreparedJob& job = session_->job();
    rv::Raster<int32_t> owner, feature;
    rv::Raster<float> distance;
    {
      py::gil_scoped_release free;
      owner = rv::owner_raster(session_->seeds(), session_->field());
      distance = rv::scaled_distance(session_->field(), job.to_output);
      feature = rv::feature_raster(session_->seeds(), session_->field(), 0, job.loaded.input_position);
    }
    py::dict d;
    d["ownership"] = to_numpy(std::move(owner));
    d["distance"] = to_numpy(std::move(distance));
    d["nearest_feature"] = to_numpy(std::move(feature));
    return d;
  }
  // The files of an ordinary job on the current seeds (process output ids -> paths); the report.
  std::string save(const std::map<std::string, std::string>& outputs) const {
    rv::OutputRequest out;
    for (const auto& [id, path] : outputs) {
      std::string* target = id == "changes" ? nullptr : rv::output_path(out, id);
      if (target == nullptr) throw rv::Error(rv::ErrorKind::invalid_argument, "outputs: no output '" + id + "'");
      *target = path;
    }
    py::gil_scoped_release free;
    return rv::json_text(session_->save(out).report, 2);
  }

 private:
  std::unique_ptr<rv::Session> session_;
};

py::list keywords() {
  py::list out;
  for (const rv::OptionSpec& o : rv::job_options()) {
    if (!is_run_keyword(o)) continue;
    py::dict d;
    d["run_only"] = !is_keyword(o);  // rvoronoi.run's alone (how its files are written)
    d["keyword"] = rv::option_keyword(o);
    d["input"] = std::string(o.input);  // the process input it is ("" = the CLI's and the module's only)
    d["type"] = type_name(o.type);
    d["section"] = std::string(o.section);
    d["title"] = std::string(o.title);
    d["help"] = std::string(o.help);
    d["default"] = std::string(o.default_text);
    d["metavar"] = std::string(o.metavar);
    py::list choices;
    for (std::string_view c : o.choices) choices.append(std::string(c.substr(0, c.find('|'))));
    d["choices"] = choices;
    d["repeatable"] = o.repeatable;
    out.append(d);
  }
  return out;
}

// rvoronoi.describe: the façade's description of seed files, as the daemon's describe-seeds
// gives it (rv/seed_description.hpp), in JSON text.
std::string describe_seeds(const std::vector<std::string>& paths, const std::string& crs, bool features) {
  rv::SeedReadOptions read;
  read.paths = paths;
  read.target_crs = crs;
  rv::SeedInventory inventory;
  {
    py::gil_scoped_release free;
    inventory = rv::describe_seeds(read, {}, features);
  }
  return rv::json_text(rv::seed_description(inventory, features));
}

}  // namespace

PYBIND11_MODULE(_rvoronoi, m) {
  m.doc() = "rvoronoi's engine (use the rvoronoi package, not this module)";
  m.attr("version") = std::string(rv::kVersion);
  // rvoronoi.Error and one subclass per kind of the error table, each also a subclass of the
  // built-in exception a Python caller would catch for it.
  py::object base = py::reinterpret_steal<py::object>(
      PyErr_NewExceptionWithDoc("rvoronoi.Error", "An error of rvoronoi; .kind names its kind.", nullptr, nullptr));
  m.attr("Error") = base;
  py::module_ builtins = py::module_::import("builtins");
  auto builtin_for = [&](rv::ErrorKind k) -> py::object {
    switch (k) {
      case rv::ErrorKind::invalid_argument:
      case rv::ErrorKind::invalid_input:
      case rv::ErrorKind::conflict:
      case rv::ErrorKind::too_large:
        return builtins.attr("ValueError");
      case rv::ErrorKind::not_found:
        return builtins.attr("LookupError");
      case rv::ErrorKind::unsupported:
        return builtins.attr("NotImplementedError");
      case rv::ErrorKind::io:
        return builtins.attr("OSError");
      case rv::ErrorKind::internal:
        return builtins.attr("RuntimeError");
      case rv::ErrorKind::cancelled:
      case rv::ErrorKind::busy:
      case rv::ErrorKind::over_quota:
        break;
    }
    return py::none();
  };
  auto& classes = error_classes();
  py::list kinds;
  for (int i = 0; i <= static_cast<int>(rv::ErrorKind::internal); ++i) {
    const auto kind = static_cast<rv::ErrorKind>(i);
    const rv::ErrorInfo& info = rv::error_info(kind);
    const std::string name = "rvoronoi." + std::string(info.python);
    py::object extra = builtin_for(kind);
    py::tuple bases = extra.is_none() ? py::make_tuple(base) : py::make_tuple(base, extra);
    py::object cls = py::reinterpret_steal<py::object>(
        PyErr_NewExceptionWithDoc(name.c_str(), std::string(info.title).c_str(), bases.ptr(), nullptr));
    cls.attr("kind") = std::string(rv::to_string(kind));
    m.attr(std::string(info.python).c_str()) = cls;
    classes.push_back(cls);
    kinds.append(py::make_tuple(std::string(rv::to_string(kind)), std::string(info.python)));
  }
  m.attr("error_kinds") = kinds;
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const rv::Error& e) {
      PyErr_SetString(error_classes()[static_cast<size_t>(e.kind())].ptr(), e.what());
    } catch (const std::bad_alloc&) {
      PyErr_SetString(error_classes()[static_cast<size_t>(rv::ErrorKind::too_large)].ptr(),
                      "out of memory: the grid does not fit; use chunks");
    }
  });
  // The daemon's default grid limit, the default of rvoronoi.compute(max_cells=...).
  m.attr("default_max_cells") = rv::JobLimits{}.max_cells;
  m.def("keywords", &keywords, "The keyword options of rvoronoi.compute, from the option table.");
  m.def(
      "process_description", [] { return rv::json_text(rv::process_description(""), 2); },
      "The process description of 'voronoi' as JSON text, as the daemon serves it (use rvoronoi.process_description).");
  m.def("run_files", &run_files, py::arg("seeds"), py::arg("options"), py::arg("outputs"), py::arg("progress"),
        py::arg("cancelled"), py::arg("max_cells") = rv::JobLimits{}.max_cells,
        "A whole job's files, as the CLI writes them (use rvoronoi.run).");
  m.def("describe_seeds", &describe_seeds, py::arg("paths"), py::arg("crs"), py::arg("features"),
        "The description of seed files as JSON text (use rvoronoi.describe).");
  py::class_<Job>(m, "Job")
      .def(py::init<const std::vector<std::string>&, const std::string&, const std::optional<std::vector<int64_t>>&,
                    int64_t>(),
           py::arg("seeds"), py::arg("options"), py::arg("window") = py::none(),
           py::arg("max_cells") = rv::JobLimits{}.max_cells)
      .def_property_readonly("grid", &Job::grid)
      .def_property_readonly("owners", &Job::owners)
      .def_property_readonly("unit", &Job::unit)
      .def_property_readonly("metric", &Job::metric)
      .def("run", &Job::run, py::arg("window"), py::arg("products"), py::arg("outputs"), py::arg("describe") = true);
  py::class_<Session>(m, "Session")
      .def(py::init<const std::vector<std::string>&, const std::string&, const std::vector<std::string>&, int,
                    int64_t>(),
           py::arg("seeds"), py::arg("options"), py::arg("deliverables"), py::arg("undo_depth") = 50,
           py::arg("max_cells") = rv::JobLimits{}.max_cells)
      .def("edit", &Session::edit, py::arg("edits"))
      .def("undo", &Session::undo)
      .def("redo", &Session::redo)
      .def("info", &Session::info)
      .def("features", &Session::features)
      .def("deliverables", &Session::deliverables)
      .def("deliverable", &Session::deliverable, py::arg("name"))
      .def("line_ids", &Session::line_ids)
      .def("arrays", &Session::arrays)
      .def("save", &Session::save, py::arg("outputs"))
      .def_property_readonly("grid", &Session::grid)
      .def_property_readonly("owners", &Session::owners)
      .def_property_readonly("unit", &Session::unit)
      .def_property_readonly("metric", &Session::metric);
}
