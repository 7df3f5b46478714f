#include "io/fmi/import/fmu_model.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <utility>

#include "io/fmi/import/fmu_archive.hpp"

namespace hvac_twin::fmi {

class FmuLibrary {
 public:
  ~FmuLibrary() {
    if (handle != nullptr) dlclose(handle);
  }
  ModelDescription description;
  std::string directory;
  void* handle = nullptr;
  fmi2InstantiateTYPE instantiate = nullptr;
  fmi2FreeInstanceTYPE free_instance = nullptr;
  fmi2SetupExperimentTYPE setup_experiment = nullptr;
  fmi2EnterInitializationModeTYPE enter_initialization = nullptr;
  fmi2ExitInitializationModeTYPE exit_initialization = nullptr;
  fmi2NewDiscreteStatesTYPE new_discrete_states = nullptr;
  fmi2EnterContinuousTimeModeTYPE enter_continuous = nullptr;
  fmi2SetTimeTYPE set_time = nullptr;
  fmi2SetRealTYPE set_real = nullptr;
  fmi2GetRealTYPE get_real = nullptr;
  fmi2SetContinuousStatesTYPE set_states = nullptr;
  fmi2GetDerivativesTYPE get_derivatives = nullptr;
  fmi2GetContinuousStatesTYPE get_states = nullptr;
  fmi2GetDirectionalDerivativeTYPE directional = nullptr;  // when provided
};

namespace {

template <class F>
void bind(FmuLibrary& lib, F& fn, const char* name, const std::string& so) {
  fn = reinterpret_cast<F>(dlsym(lib.handle, name));
  if (fn == nullptr) throw FmuError(so + ": does not export " + name);
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FmuError(path + ": missing from the FMU (an FMU must contain it)");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

std::shared_ptr<const FmuLibrary> load_fmu(const std::string& fmu_path,
                                           const std::string& unpack_directory) {
  unpack_fmu(fmu_path, unpack_directory);
  auto lib = std::make_shared<FmuLibrary>();
  lib->directory = std::filesystem::absolute(unpack_directory).string();
  const std::string xml_path = lib->directory + "/modelDescription.xml";
  lib->description = parse_model_description(read_file(xml_path), fmu_path);
  const std::string so =
      lib->directory + "/binaries/linux64/" + lib->description.model_identifier + ".so";
  std::error_code ec;
  if (!std::filesystem::is_regular_file(so, ec))
    throw FmuError(fmu_path + ": no linux64 binary (binaries/linux64/" +
                   lib->description.model_identifier + ".so)");
  lib->handle = dlopen(so.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (lib->handle == nullptr) throw FmuError(so + ": cannot load: " + dlerror());
  auto get_version = reinterpret_cast<fmi2GetVersionTYPE>(dlsym(lib->handle, "fmi2GetVersion"));
  if (get_version == nullptr) throw FmuError(so + ": does not export fmi2GetVersion");
  const std::string version = get_version();
  if (version != "2.0")
    throw FmuError(so + ": fmi2GetVersion() is \"" + version + "\", not \"2.0\"");
  bind(*lib, lib->instantiate, "fmi2Instantiate", so);
  bind(*lib, lib->free_instance, "fmi2FreeInstance", so);
  bind(*lib, lib->setup_experiment, "fmi2SetupExperiment", so);
  bind(*lib, lib->enter_initialization, "fmi2EnterInitializationMode", so);
  bind(*lib, lib->exit_initialization, "fmi2ExitInitializationMode", so);
  bind(*lib, lib->new_discrete_states, "fmi2NewDiscreteStates", so);
  bind(*lib, lib->enter_continuous, "fmi2EnterContinuousTimeMode", so);
  bind(*lib, lib->set_time, "fmi2SetTime", so);
  bind(*lib, lib->set_real, "fmi2SetReal", so);
  bind(*lib, lib->get_real, "fmi2GetReal", so);
  bind(*lib, lib->set_states, "fmi2SetContinuousStates", so);
  bind(*lib, lib->get_derivatives, "fmi2GetDerivatives", so);
  bind(*lib, lib->get_states, "fmi2GetContinuousStates", so);
  // Only an FMU that says it provides them is asked for directional derivatives.
  if (lib->description.provides_directional_derivative)
    bind(*lib, lib->directional, "fmi2GetDirectionalDerivative", so);
  return lib;
}

const ModelDescription& description_of(const FmuLibrary& library) {
  return library.description;
}

std::vector<std::size_t> fmu_disturbances(const ModelDescription& d,
                                          const plant::ParameterMap& params) {
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < d.inputs.size(); ++k) {
    const auto it = params.find(kAugmentPrefix + d.variables[d.inputs[k]].name);
    if (it != params.end() && it->second != 0.0) out.push_back(k);
  }
  return out;
}

namespace {

// The hvac-twin annotation attribute `key` of `v` as a number, or `fallback` when absent.
double tool_number(const FmuVariable& v, const char* key, double fallback) {
  const auto it = v.tool.find(key);
  if (it == v.tool.end()) return fallback;
  char* end = nullptr;
  const double value = std::strtod(it->second.c_str(), &end);
  if (end == it->second.c_str() || *end != '\0')
    throw FmuError("variable \"" + v.name + "\": hvac-twin annotation " + key + "=\"" + it->second +
                   "\" is not a number");
  return value;
}

bool tool_flag(const FmuVariable& v, const char* key) {
  const auto it = v.tool.find(key);
  return it != v.tool.end() && it->second == "true";
}

std::size_t index_of(const auto& list, const std::string& name, const std::string& what) {
  if (const auto i = plant::ModelLayout::find(list, name)) return *i;
  throw FmuError("hvac-twin annotation: " + what + " \"" + name + "\" is not in the model");
}

// A state's filter settings from its annotation (io/fmi/annotations.hpp), when it has one.
void annotate_state(const FmuVariable& v, const plant::ModelLayout& layout, plant::StateInfo& s) {
  if (v.tool.empty()) return;
  s.initial_std = tool_number(v, "initialStd", s.initial_std);
  s.process_noise = tool_number(v, "processNoise", s.process_noise);
  s.reuse_scale = tool_number(v, "reuseScale", s.reuse_scale);
  s.augmented = tool_flag(v, "augmented");
  s.consider = tool_flag(v, "consider");
  s.calibrate = tool_flag(v, "calibrate");
  s.held_while_settling = tool_flag(v, "heldWhileSettling");
  s.persistent = tool_flag(v, "persistent");
  if (const auto it = v.tool.find("excitedBy"); it != v.tool.end()) {
    s.excited_by = static_cast<int>(index_of(layout.inputs, it->second, "input"));
    s.excitation_min = tool_number(v, "excitationMin", 0.0);
  }
}

plant::LinearConstraint constraint_of(const ToolConstraint& t, const plant::ModelLayout& layout) {
  plant::LinearConstraint c;
  c.name = t.name;
  c.over = t.over_outputs ? plant::LinearConstraint::Over::kOutputs
                          : plant::LinearConstraint::Over::kStates;
  c.bound = t.bound;
  for (const auto& [name, coefficient] : t.terms)
    c.terms.emplace_back(t.over_outputs ? index_of(layout.outputs, name, "output")
                                        : index_of(layout.states, name, "state"),
                         coefficient);
  if (!t.while_input.empty()) {
    c.while_input = static_cast<int>(index_of(layout.inputs, t.while_input, "input"));
    c.while_above = t.while_above;
  }
  return c;
}

}  // namespace

plant::ModelLayout fmu_layout(const ModelDescription& d, const plant::ParameterMap& params) {
  plant::ModelLayout layout;
  const auto unit = [](const std::string& u) { return u.empty() ? std::string("1") : u; };
  for (std::size_t i : d.states) {
    const FmuVariable& v = d.variables[i];
    plant::StateInfo s;
    s.name = v.name;
    s.unit = unit(v.unit);
    s.min = v.min;
    s.max = v.max;
    s.initial = std::isnan(v.start) ? 0.0 : v.start;
    s.initial_std = 0.1 * std::max(std::abs(s.initial), std::abs(v.nominal));
    s.abs_tol = 1e-6 * std::abs(v.nominal);
    s.description = v.description;
    layout.states.push_back(s);
  }
  for (std::size_t i : d.inputs) {
    const FmuVariable& v = d.variables[i];
    layout.inputs.push_back({v.name, unit(v.unit), v.min, v.max, v.start, v.description});
  }
  for (std::size_t k = 0; k < d.states.size(); ++k)
    annotate_state(d.variables[d.states[k]], layout, layout.states[k]);
  for (std::size_t k : fmu_disturbances(d, params)) {
    const FmuVariable& v = d.variables[d.inputs[k]];
    const double width = v.max - v.min;
    const bool bounded = std::isfinite(width) && width > 0.0;
    plant::StateInfo s;
    s.name = v.name + kDisturbanceSuffix;
    s.unit = unit(v.unit);
    s.min = bounded ? -width : -std::numeric_limits<double>::infinity();
    s.max = bounded ? width : std::numeric_limits<double>::infinity();
    s.initial = 0.0;
    s.initial_std = bounded ? 0.1 * width : 1.0;
    s.augmented = true;
    s.description = "unknown additive disturbance of input " + v.name + " (random walk)";
    layout.states.push_back(s);
  }
  for (std::size_t i : d.outputs) {
    const FmuVariable& v = d.variables[i];
    layout.outputs.push_back({v.name, unit(v.unit), v.min, v.max, plant::kRequired, v.description,
                              tool_number(v, "modelError", 0.0),
                              tool_number(v, "modelErrorRel", 0.0)});
  }
  for (const ToolConstraint& t : d.constraints)
    layout.constraints.push_back(constraint_of(t, layout));
  return layout;
}

void FmuModel::logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                      fmi2String category, fmi2String message, ...) {
  if (env == nullptr || status < fmi2Error) return;  // warnings and debug output are dropped
  char text[512] = "";
  if (message != nullptr) {
    va_list args;
    va_start(args, message);
    // The FMU hands the format (FMI 2.0 2.1.5: the message is a printf format, with its
    // arguments after it): it cannot be a literal here.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
    std::vsnprintf(text, sizeof text, message, args);
#pragma GCC diagnostic pop
    va_end(args);
  }
  static_cast<FmuModel*>(env)->last_error_ = std::string(instance == nullptr ? "" : instance) +
                                             " [" + (category == nullptr ? "" : category) +
                                             "]: " + text;
}

FmuModel::FmuModel(std::shared_ptr<const FmuLibrary> library, FmuOptions options)
    : lib_(std::move(library)), options_(std::move(options)) {
  const ModelDescription& d = lib_->description;
  const auto& vars = d.variables;
  layout_ = fmu_layout(d, options_.parameters);
  for (std::size_t k = 0; k < d.states.size(); ++k) {
    state_refs_.push_back(vars[d.states[k]].ref);
    derivative_refs_.push_back(vars[d.derivatives[k]].ref);
    nominal_.push_back(std::abs(vars[d.states[k]].nominal));
  }
  for (std::size_t i : d.inputs)
    input_refs_.push_back(vars[i].ref);
  disturbed_ = fmu_disturbances(d, options_.parameters);
  nominal_.resize(layout_.states.size(), 1.0);
  u_effective_.resize(input_refs_.size());
  for (std::size_t i : d.outputs)
    output_refs_.push_back(vars[i].ref);
  std::vector<fmi2ValueReference> param_refs;
  std::vector<double> param_values;
  for (const auto& [name, value] : options_.parameters) {
    if (name.rfind(kAugmentPrefix, 0) == 0) {
      const FmuVariable* input = d.find(name.substr(std::string(kAugmentPrefix).size()));
      if (input == nullptr || input->causality != "input" || (value != 0.0 && value != 1.0))
        throw FmuError("FMU " + d.model_name + ": \"" + name +
                       "\" is not 0 or 1 for an input of the model");
      continue;  // not the FMU's: a disturbance state of ours
    }
    const FmuVariable* v = d.find(name);
    if (v == nullptr || v->causality != "parameter" || v->type != "Real")
      throw FmuError("FMU " + d.model_name + ": \"" + name + "\" is not a Real parameter");
    if (!(value >= v->min && value <= v->max))
      throw FmuError("FMU " + d.model_name + ": parameter \"" + name +
                     "\" = " + std::to_string(value) + " is outside its range");
    param_refs.push_back(v->ref);
    param_values.push_back(value);
  }
  method_ = lib_->directional != nullptr && !options_.finite_differences
                ? JacobianMethod::kDirectionalDerivative
                : JacobianMethod::kFiniteDifferences;
  const std::size_t n = layout_.states.size();
  x_try_.resize(n);
  f_plus_.resize(std::max(n, output_refs_.size()));
  f_minus_.resize(std::max(n, output_refs_.size()));

  callbacks_.logger = &FmuModel::logger;
  callbacks_.allocateMemory = [](std::size_t count, std::size_t size) {
    return std::calloc(count, size);
  };
  callbacks_.freeMemory = [](void* p) { std::free(p); };
  callbacks_.componentEnvironment = this;
  const std::string resources = "file://" + lib_->directory + "/resources";
  component_ = lib_->instantiate(options_.instance_name.c_str(), fmi2ModelExchange, d.guid.c_str(),
                                 resources.c_str(), &callbacks_, fmi2False, fmi2False);
  if (component_ == nullptr)
    throw FmuError("FMU " + d.model_name + ": fmi2Instantiate refused: " + last_error_);
  // A throwing constructor runs no destructor: the instance is freed here.
  const auto check = [&](fmi2Status s, const char* call) {
    if (s <= fmi2Warning) return;
    lib_->free_instance(component_);
    component_ = nullptr;
    throw FmuError("FMU " + d.model_name + ": " + call + " failed: " + last_error_);
  };
  check(lib_->setup_experiment(component_, fmi2False, 0.0, 0.0, fmi2False, 0.0),
        "fmi2SetupExperiment");
  if (!param_refs.empty())
    check(lib_->set_real(component_, param_refs.data(), param_refs.size(), param_values.data()),
          "fmi2SetReal (parameters)");
  check(lib_->enter_initialization(component_), "fmi2EnterInitializationMode");
  check(lib_->exit_initialization(component_), "fmi2ExitInitializationMode");
  fmi2EventInfo info{};
  info.newDiscreteStatesNeeded = fmi2True;
  for (int i = 0; i < 100 && info.newDiscreteStatesNeeded != fmi2False; ++i)
    check(lib_->new_discrete_states(component_, &info), "fmi2NewDiscreteStates");
  if (info.newDiscreteStatesNeeded != fmi2False)
    check(fmi2Error, "fmi2NewDiscreteStates (the event iteration did not converge)");
  check(lib_->enter_continuous(component_), "fmi2EnterContinuousTimeMode");
  check(lib_->set_time(component_, 0.0), "fmi2SetTime");
  // The initial estimate: the state the FMU's initialisation computed (with the parameters set
  // above; a state whose description gives no start value has one only here).
  std::vector<double> x0(state_refs_.size());
  check(lib_->get_states(component_, x0.data(), x0.size()), "fmi2GetContinuousStates");
  for (std::size_t k = 0; k < x0.size(); ++k)
    if (std::isfinite(x0[k])) layout_.states[k].initial = x0[k];
}

FmuModel::~FmuModel() {
  if (component_ != nullptr) lib_->free_instance(component_);
}

std::unique_ptr<plant::ContinuousModel> FmuModel::clone() const {
  return std::make_unique<FmuModel>(lib_, options_);
}

int FmuModel::status(fmi2Status s, const char* call) const {
  if (s <= fmi2Warning) return plant::kModelOk;
  if (s == fmi2Discard) return plant::kModelRecoverable;
  failed_ = true;
  if (last_error_.empty()) last_error_ = std::string(call) + " failed";
  return plant::kModelFatal;
}

int FmuModel::set(std::span<const double> x, std::span<const double> u) const {
  if (failed_) return plant::kModelFatal;
  const std::size_t nf = state_refs_.size();
  if (x.size() != layout_.states.size() || u.size() != input_refs_.size())
    return plant::kModelFatal;
  int s = status(lib_->set_states(component_, x.data(), nf), "fmi2SetContinuousStates");
  if (s != plant::kModelOk || u.empty()) return s;
  std::copy(u.begin(), u.end(), u_effective_.begin());
  for (std::size_t k = 0; k < disturbed_.size(); ++k)
    u_effective_[disturbed_[k]] += x[nf + k];
  return status(lib_->set_real(component_, input_refs_.data(), u.size(), u_effective_.data()),
                "fmi2SetReal");
}

int FmuModel::eval(bool outputs, std::span<const double> x, std::span<const double> u,
                   std::span<double> out) const {
  if (const int s = set(x, u); s != plant::kModelOk) return s;
  if (outputs)
    return status(lib_->get_real(component_, output_refs_.data(), output_refs_.size(), out.data()),
                  "fmi2GetReal");
  const std::size_t nf = state_refs_.size();
  std::fill(out.begin() + static_cast<std::ptrdiff_t>(nf), out.end(), 0.0);  // disturbances
  return status(lib_->get_derivatives(component_, out.data(), nf), "fmi2GetDerivatives");
}

int FmuModel::rhs(std::span<const double> x, std::span<const double> u,
                  std::span<double> xdot) const {
  return eval(false, x, u, xdot);
}

int FmuModel::outputs(std::span<const double> x, std::span<const double> u,
                      std::span<double> y) const {
  return eval(true, x, u, y);
}

int FmuModel::rhs_jacobian(std::span<const double> x, std::span<const double> u,
                           std::span<double> xdot, std::span<double> jac) const {
  return jacobian(false, x, u, xdot, jac);
}

int FmuModel::output_jacobian(std::span<const double> x, std::span<const double> u,
                              std::span<double> y, std::span<double> jac) const {
  return jacobian(true, x, u, y, jac);
}

int FmuModel::jacobian(bool outputs, std::span<const double> x, std::span<const double> u,
                       std::span<double> value, std::span<double> jac) const {
  const std::size_t n = layout_.states.size(), nf = state_refs_.size();
  const std::size_t rows = outputs ? output_refs_.size() : n;
  const std::size_t fmu_rows = outputs ? rows : nf;  // below them: the disturbances' zero rows
  const std::vector<fmi2ValueReference>& unknowns = outputs ? output_refs_ : derivative_refs_;
  if (!value.empty())
    if (const int s = eval(outputs, x, u, value); s != plant::kModelOk) return s;
  if (method_ == JacobianMethod::kDirectionalDerivative) {
    if (value.empty())
      if (const int s = set(x, u); s != plant::kModelOk) return s;
    const double one = 1.0;
    for (std::size_t j = 0; j < n; ++j) {
      // A disturbance moves its input: the column is the derivative with respect to the input.
      const fmi2ValueReference* known = j < nf ? &state_refs_[j] : &input_refs_[disturbed_[j - nf]];
      double* column = jac.data() + j * rows;
      const int s =
          status(lib_->directional(component_, unknowns.data(), fmu_rows, known, 1, &one, column),
                 "fmi2GetDirectionalDerivative");
      if (s != plant::kModelOk) return s;
      std::fill(column + fmu_rows, column + rows, 0.0);
    }
    return plant::kModelOk;
  }
  // Central differences, step cbrt(eps) max(|x_j|, nominal_j).
  static const double kStep = std::cbrt(std::numeric_limits<double>::epsilon());
  std::copy(x.begin(), x.end(), x_try_.begin());
  const std::span<double> plus(f_plus_.data(), rows), minus(f_minus_.data(), rows);
  for (std::size_t j = 0; j < n; ++j) {
    const double h = kStep * std::max(std::abs(x[j]), nominal_[j]);
    x_try_[j] = x[j] + h;
    int s = eval(outputs, x_try_, u, plus);
    x_try_[j] = x[j] - h;
    if (s == plant::kModelOk) s = eval(outputs, x_try_, u, minus);
    x_try_[j] = x[j];
    if (s != plant::kModelOk) return s;
    for (std::size_t r = 0; r < rows; ++r)
      jac[j * rows + r] = (plus[r] - minus[r]) / (2.0 * h);
  }
  return plant::kModelOk;
}

}  // namespace hvac_twin::fmi
