// The FMI 2.0 Model Exchange functions of an exported built-in model (HVAC_TWIN_FMU_TYPE, set
// per FMU by CMake): the model's rhs, outputs and exact AD Jacobians behind the standard's C API.
// Every function catches what the model code might throw: nothing crosses the C boundary.
//
// Directional derivatives: with respect to states from the AD Jacobians (exact, cached until a
// state or input changes); with respect to inputs by a central difference along the seed, step
// cbrt(machine epsilon) * max(1, max |u_k|) (the model interface has no input Jacobian).
#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "io/fmi/export/fmu_description.hpp"
#include "io/fmi/fmi2.hpp"
#include "plant_models/catalog.hpp"

#ifndef HVAC_TWIN_FMU_TYPE
#error "HVAC_TWIN_FMU_TYPE names the built-in model this FMU exports"
#endif

#define FMI2_EXPORT extern "C" __attribute__((visibility("default")))

namespace {

using hvac_twin::fmi::ExportedModel;
namespace plant = hvac_twin::plant;

#ifndef HVAC_TWIN_FMU_STRUCTURE
#define HVAC_TWIN_FMU_STRUCTURE ""
#endif

const ExportedModel& exported() {
  static const ExportedModel m =
      hvac_twin::fmi::describe_builtin(HVAC_TWIN_FMU_TYPE, HVAC_TWIN_FMU_STRUCTURE);
  return m;
}

enum class Mode { kInstantiated, kInitialization, kEvent, kContinuous, kTerminated, kError };

struct Instance {
  const ExportedModel* d = nullptr;
  std::string name;
  fmi2CallbackFunctions cb{};
  bool logging = false;
  Mode mode = Mode::kInstantiated;
  plant::ParameterMap params;
  std::unique_ptr<plant::ContinuousModel> model;
  std::vector<double> x, u, xdot, y, jac, hjac, u_step;
  std::vector<std::pair<std::size_t, double>> dx;  // a directional derivative's state seeds
  bool have_xdot = false, have_y = false, have_jac = false, have_hjac = false;

  void log(fmi2Status status, const char* category, const std::string& message) const {
    if (cb.logger != nullptr && (logging || status >= fmi2Error))
      cb.logger(cb.componentEnvironment, name.c_str(), status, category, "%s", message.c_str());
  }
  fmi2Status fail(const std::string& message, fmi2Status status = fmi2Error) {
    log(status, "logStatusError", message);
    if (status == fmi2Fatal) mode = Mode::kError;
    return status;
  }
  void touched() { have_xdot = have_y = have_jac = have_hjac = false; }
};

Instance* as_instance(fmi2Component c) {
  return static_cast<Instance*>(c);
}

fmi2Status from_model(int status) {
  if (status == plant::kModelOk) return fmi2OK;
  return status > 0 ? fmi2Discard : fmi2Error;
}

fmi2Status build_model(Instance& in) {
  plant::ParameterMap all = in.params;
  for (const auto& p : in.d->structural)
    all[p.name] = p.default_value;  // the value the FMU was built with
  in.model = plant::create_model(in.d->type, all);
  in.touched();
  return fmi2OK;
}

fmi2Status ensure_model(Instance& in) {
  return in.model ? fmi2OK : build_model(in);
}

fmi2Status eval_xdot(Instance& in) {
  if (in.have_xdot) return fmi2OK;
  if (const fmi2Status s = ensure_model(in); s != fmi2OK) return s;
  const fmi2Status s = from_model(in.model->rhs(in.x, in.u, in.xdot));
  in.have_xdot = s == fmi2OK;
  return s;
}

fmi2Status eval_y(Instance& in) {
  if (in.have_y) return fmi2OK;
  if (const fmi2Status s = ensure_model(in); s != fmi2OK) return s;
  const fmi2Status s = from_model(in.model->outputs(in.x, in.u, in.y));
  in.have_y = s == fmi2OK;
  return s;
}

// Runs `body` with the instance, turning exceptions into fmi2Error.
template <class F>
fmi2Status guarded(fmi2Component c, const char* what, F&& body) {
  Instance* in = as_instance(c);
  if (in == nullptr) return fmi2Error;
  if (in->mode == Mode::kError) return in->fail(std::string(what) + ": the instance failed before");
  try {
    return body(*in);
  } catch (const std::exception& e) {
    return in->fail(std::string(what) + ": " + e.what());
  } catch (...) {
    return in->fail(std::string(what) + ": unknown exception", fmi2Fatal);
  }
}

enum class Kind { kState, kDerivative, kInput, kOutput, kParameter, kStructural, kNone };

Kind kind_of(const ExportedModel& d, fmi2ValueReference r, std::size_t& index) {
  const std::size_t n = d.n(), p = d.layout.inputs.size(), m = d.layout.outputs.size();
  const std::size_t t = d.tunable.size(), s = d.structural.size();
  std::size_t k = r;
  const auto in_range = [&](std::size_t size) {
    if (k < size) return true;
    k -= size;
    return false;
  };
  Kind kind = Kind::kNone;
  if (in_range(n))
    kind = Kind::kState;
  else if (in_range(n))
    kind = Kind::kDerivative;
  else if (in_range(p))
    kind = Kind::kInput;
  else if (in_range(m))
    kind = Kind::kOutput;
  else if (in_range(t))
    kind = Kind::kParameter;
  else if (in_range(s))
    kind = Kind::kStructural;
  index = k;
  return kind;
}

// The directional derivative sum_k d(unknown)/d(known_k) seed_k.
fmi2Status directional(Instance& in, const fmi2ValueReference unknown[], std::size_t n_unknown,
                       const fmi2ValueReference known[], std::size_t n_known, const fmi2Real seed[],
                       fmi2Real out[]) {
  const ExportedModel& d = *in.d;
  const std::size_t n = d.n(), m = d.layout.outputs.size();
  if (const fmi2Status s = ensure_model(in); s != fmi2OK) return s;
  bool any_input = false;
  std::fill(in.u_step.begin(), in.u_step.end(), 0.0);
  std::vector<std::pair<std::size_t, double>>& dx = in.dx;
  dx.clear();
  for (std::size_t k = 0; k < n_known; ++k) {
    std::size_t i = 0;
    const Kind kind = kind_of(d, known[k], i);
    if (kind == Kind::kState) {
      dx.emplace_back(i, seed[k]);
    } else if (kind == Kind::kInput) {
      in.u_step[i] += seed[k];
      any_input = true;
    } else {
      return in.fail("fmi2GetDirectionalDerivative: value reference " + std::to_string(known[k]) +
                     " is not a state or an input");
    }
  }
  bool need_f = false, need_h = false;
  for (std::size_t k = 0; k < n_unknown; ++k) {
    std::size_t i = 0;
    const Kind kind = kind_of(d, unknown[k], i);
    if (kind == Kind::kDerivative)
      need_f = true;
    else if (kind == Kind::kOutput)
      need_h = true;
    else
      return in.fail("fmi2GetDirectionalDerivative: value reference " + std::to_string(unknown[k]) +
                     " is not a derivative or an output");
  }
  if (need_f && !in.have_jac) {
    const fmi2Status s = from_model(in.model->rhs_jacobian(in.x, in.u, {}, in.jac));
    if (s != fmi2OK) return s;
    in.have_jac = true;
  }
  if (need_h && !in.have_hjac) {
    const fmi2Status s = from_model(in.model->output_jacobian(in.x, in.u, {}, in.hjac));
    if (s != fmi2OK) return s;
    in.have_hjac = true;
  }
  // Inputs: central difference along the seed.
  double h = 0.0;
  if (any_input) {
    double scale = 1.0;
    for (double v : in.u)
      scale = std::max(scale, std::abs(v));
    h = std::cbrt(std::numeric_limits<double>::epsilon()) * scale;
  }
  const auto input_part = [&](bool outputs, std::size_t row, double& value) -> fmi2Status {
    if (!any_input) return fmi2OK;
    std::vector<double> up = in.u, um = in.u;
    for (std::size_t j = 0; j < up.size(); ++j) {
      up[j] += h * in.u_step[j];
      um[j] -= h * in.u_step[j];
    }
    std::vector<double> fp(outputs ? m : n), fm(outputs ? m : n);
    int sp = outputs ? in.model->outputs(in.x, up, fp) : in.model->rhs(in.x, up, fp);
    int sm = outputs ? in.model->outputs(in.x, um, fm) : in.model->rhs(in.x, um, fm);
    if (sp != plant::kModelOk || sm != plant::kModelOk) return from_model(sp != 0 ? sp : sm);
    value += (fp[row] - fm[row]) / (2.0 * h);
    return fmi2OK;
  };
  for (std::size_t k = 0; k < n_unknown; ++k) {
    std::size_t row = 0;
    const bool outputs = kind_of(d, unknown[k], row) == Kind::kOutput;
    const std::vector<double>& a = outputs ? in.hjac : in.jac;
    const std::size_t rows = outputs ? m : n;
    double v = 0.0;
    for (const auto& [col, s] : dx)
      v += a[col * rows + row] * s;
    if (const fmi2Status s = input_part(outputs, row, v); s != fmi2OK) return s;
    out[k] = v;
  }
  return fmi2OK;
}

fmi2Status set_real(Instance& in, const fmi2ValueReference vr[], std::size_t nvr,
                    const fmi2Real value[]) {
  const ExportedModel& d = *in.d;
  for (std::size_t k = 0; k < nvr; ++k) {
    std::size_t i = 0;
    switch (kind_of(d, vr[k], i)) {
      case Kind::kState:
        in.x[i] = value[k];
        break;
      case Kind::kInput:
        in.u[i] = value[k];
        break;
      case Kind::kParameter: {
        if (in.mode != Mode::kInstantiated && in.mode != Mode::kInitialization)
          return in.fail("fmi2SetReal: parameter " + d.tunable[i].name +
                         " is fixed after initialisation");
        const auto& p = d.tunable[i];
        if (!(value[k] >= p.min && value[k] <= p.max))
          return in.fail("fmi2SetReal: parameter " + p.name + " = " + std::to_string(value[k]) +
                         " is outside [" + std::to_string(p.min) + ", " + std::to_string(p.max) +
                         "]");
        in.params[p.name] = value[k];
        in.model.reset();  // rebuilt with the new value at the next evaluation
        break;
      }
      default:
        return in.fail("fmi2SetReal: value reference " + std::to_string(vr[k]) +
                       " is not a state, an input or a tunable parameter");
    }
  }
  in.touched();
  return fmi2OK;
}

fmi2Status get_real(Instance& in, const fmi2ValueReference vr[], std::size_t nvr,
                    fmi2Real value[]) {
  const ExportedModel& d = *in.d;
  for (std::size_t k = 0; k < nvr; ++k) {
    std::size_t i = 0;
    switch (kind_of(d, vr[k], i)) {
      case Kind::kState:
        value[k] = in.x[i];
        break;
      case Kind::kDerivative:
        if (const fmi2Status s = eval_xdot(in); s != fmi2OK) return s;
        value[k] = in.xdot[i];
        break;
      case Kind::kInput:
        value[k] = in.u[i];
        break;
      case Kind::kOutput:
        if (const fmi2Status s = eval_y(in); s != fmi2OK) return s;
        value[k] = in.y[i];
        break;
      case Kind::kParameter:
        value[k] = in.params.at(d.tunable[i].name);
        break;
      case Kind::kStructural:
        value[k] = d.structural[i].default_value;
        break;
      case Kind::kNone:
        return in.fail("fmi2GetReal: no variable has value reference " + std::to_string(vr[k]));
    }
  }
  return fmi2OK;
}

fmi2Status no_such_variables(Instance& in, const char* what, std::size_t nvr) {
  if (nvr == 0) return fmi2OK;
  return in.fail(std::string(what) + ": this FMU has only Real variables");
}

}  // namespace

FMI2_EXPORT const char* fmi2GetTypesPlatform() {
  return "default";
}
FMI2_EXPORT const char* fmi2GetVersion() {
  return "2.0";
}

FMI2_EXPORT fmi2Component fmi2Instantiate(fmi2String instance_name, fmi2Type type, fmi2String guid,
                                          fmi2String /*resource_location*/,
                                          const fmi2CallbackFunctions* functions,
                                          fmi2Boolean /*visible*/, fmi2Boolean logging_on) {
  const auto refuse = [&](const std::string& why) -> fmi2Component {
    if (functions != nullptr && functions->logger != nullptr)
      functions->logger(functions->componentEnvironment, instance_name, fmi2Error, "logStatusError",
                        "%s", why.c_str());
    return nullptr;
  };
  try {
    const ExportedModel& d = exported();
    if (type != fmi2ModelExchange)
      return refuse("fmi2Instantiate: this FMU supports Model Exchange only");
    if (guid == nullptr || d.guid != guid)
      return refuse("fmi2Instantiate: GUID " + std::string(guid == nullptr ? "(null)" : guid) +
                    " is not this FMU's " + d.guid);
    auto in = std::make_unique<Instance>();
    in->d = &d;
    in->name = instance_name == nullptr ? "" : instance_name;
    if (functions != nullptr) in->cb = *functions;
    in->logging = logging_on != fmi2False;
    for (const auto& p : d.tunable)
      in->params[p.name] = p.default_value;
    const std::size_t n = d.n(), p = d.layout.inputs.size(), m = d.layout.outputs.size();
    in->x.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      in->x[i] = d.layout.states[i].initial;
    in->u.resize(p);
    for (std::size_t i = 0; i < p; ++i) {
      const auto& s = d.layout.inputs[i];
      in->u[i] =
          std::isnan(s.default_value) ? std::fmin(std::fmax(0.0, s.min), s.max) : s.default_value;
    }
    in->xdot.resize(n);
    in->y.resize(m);
    in->jac.resize(n * n);
    in->hjac.resize(m * n);
    in->u_step.resize(p);
    in->dx.reserve(n);
    return in.release();
  } catch (const std::exception& e) {
    return refuse(std::string("fmi2Instantiate: ") + e.what());
  }
}

FMI2_EXPORT void fmi2FreeInstance(fmi2Component c) {
  delete as_instance(c);
}

FMI2_EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, std::size_t,
                                           const fmi2String[]) {
  Instance* in = as_instance(c);
  if (in == nullptr) return fmi2Error;
  in->logging = on != fmi2False;
  return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean, fmi2Real, fmi2Real,
                                           fmi2Boolean, fmi2Real) {
  return as_instance(c) == nullptr ? fmi2Error : fmi2OK;  // autonomous: no time dependence
}

FMI2_EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
  return guarded(c, "fmi2EnterInitializationMode", [](Instance& in) {
    in.mode = Mode::kInitialization;
    return fmi2OK;
  });
}

FMI2_EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
  return guarded(c, "fmi2ExitInitializationMode", [](Instance& in) {
    in.mode = Mode::kEvent;
    return ensure_model(in);
  });
}

FMI2_EXPORT fmi2Status fmi2Terminate(fmi2Component c) {
  return guarded(c, "fmi2Terminate", [](Instance& in) {
    in.mode = Mode::kTerminated;
    return fmi2OK;
  });
}

FMI2_EXPORT fmi2Status fmi2Reset(fmi2Component c) {
  Instance* in = as_instance(c);
  if (in == nullptr) return fmi2Error;
  for (const auto& p : in->d->tunable)
    in->params[p.name] = p.default_value;
  for (std::size_t i = 0; i < in->d->n(); ++i)
    in->x[i] = in->d->layout.states[i].initial;
  in->model.reset();
  in->touched();
  in->mode = Mode::kInstantiated;
  return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], std::size_t nvr,
                                   fmi2Real value[]) {
  return guarded(c, "fmi2GetReal", [&](Instance& in) { return get_real(in, vr, nvr, value); });
}

FMI2_EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], std::size_t nvr,
                                   const fmi2Real value[]) {
  return guarded(c, "fmi2SetReal", [&](Instance& in) { return set_real(in, vr, nvr, value); });
}

FMI2_EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference[], std::size_t nvr,
                                      fmi2Integer[]) {
  return guarded(c, "fmi2GetInteger",
                 [&](Instance& in) { return no_such_variables(in, "fmi2GetInteger", nvr); });
}
FMI2_EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference[], std::size_t nvr,
                                      const fmi2Integer[]) {
  return guarded(c, "fmi2SetInteger",
                 [&](Instance& in) { return no_such_variables(in, "fmi2SetInteger", nvr); });
}
FMI2_EXPORT fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference[], std::size_t nvr,
                                      fmi2Boolean[]) {
  return guarded(c, "fmi2GetBoolean",
                 [&](Instance& in) { return no_such_variables(in, "fmi2GetBoolean", nvr); });
}
FMI2_EXPORT fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference[], std::size_t nvr,
                                      const fmi2Boolean[]) {
  return guarded(c, "fmi2SetBoolean",
                 [&](Instance& in) { return no_such_variables(in, "fmi2SetBoolean", nvr); });
}
FMI2_EXPORT fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference[], std::size_t nvr,
                                     fmi2String[]) {
  return guarded(c, "fmi2GetString",
                 [&](Instance& in) { return no_such_variables(in, "fmi2GetString", nvr); });
}
FMI2_EXPORT fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference[], std::size_t nvr,
                                     const fmi2String[]) {
  return guarded(c, "fmi2SetString",
                 [&](Instance& in) { return no_such_variables(in, "fmi2SetString", nvr); });
}

// canGetAndSetFMUstate="false": the state functions refuse.
FMI2_EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate*) {
  return guarded(c, "fmi2GetFMUstate", [](Instance& in) {
    return in.fail("fmi2GetFMUstate: not supported (canGetAndSetFMUstate is false)");
  });
}
FMI2_EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate) {
  return fmi2GetFMUstate(c, nullptr);
}
FMI2_EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate*) {
  return fmi2GetFMUstate(c, nullptr);
}
FMI2_EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate, std::size_t*) {
  return fmi2GetFMUstate(c, nullptr);
}
FMI2_EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate, fmi2Byte[],
                                             std::size_t) {
  return fmi2GetFMUstate(c, nullptr);
}
FMI2_EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte[], std::size_t,
                                               fmi2FMUstate*) {
  return fmi2GetFMUstate(c, nullptr);
}

FMI2_EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c,
                                                    const fmi2ValueReference unknown[],
                                                    std::size_t n_unknown,
                                                    const fmi2ValueReference known[],
                                                    std::size_t n_known, const fmi2Real seed[],
                                                    fmi2Real sensitivity[]) {
  return guarded(c, "fmi2GetDirectionalDerivative", [&](Instance& in) {
    return directional(in, unknown, n_unknown, known, n_known, seed, sensitivity);
  });
}

// --- Model Exchange -----------------------------------------------------------------------------

FMI2_EXPORT fmi2Status fmi2EnterEventMode(fmi2Component c) {
  return guarded(c, "fmi2EnterEventMode", [](Instance& in) {
    in.mode = Mode::kEvent;
    return fmi2OK;
  });
}

FMI2_EXPORT fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo* info) {
  return guarded(c, "fmi2NewDiscreteStates", [&](Instance&) {
    *info = fmi2EventInfo{};  // no discrete states, no time events
    return fmi2OK;
  });
}

FMI2_EXPORT fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
  return guarded(c, "fmi2EnterContinuousTimeMode", [](Instance& in) {
    in.mode = Mode::kContinuous;
    return fmi2OK;
  });
}

FMI2_EXPORT fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean,
                                                   fmi2Boolean* enter_event_mode,
                                                   fmi2Boolean* terminate_simulation) {
  return guarded(c, "fmi2CompletedIntegratorStep", [&](Instance&) {
    *enter_event_mode = fmi2False;
    *terminate_simulation = fmi2False;
    return fmi2OK;
  });
}

FMI2_EXPORT fmi2Status fmi2SetTime(fmi2Component c, fmi2Real) {
  return as_instance(c) == nullptr ? fmi2Error : fmi2OK;  // autonomous
}

FMI2_EXPORT fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[],
                                               std::size_t nx) {
  return guarded(c, "fmi2SetContinuousStates", [&](Instance& in) {
    if (nx != in.x.size())
      return in.fail("fmi2SetContinuousStates: " + std::to_string(nx) + " states given, the " +
                     "model has " + std::to_string(in.x.size()));
    std::copy(x, x + nx, in.x.begin());
    in.touched();
    return fmi2OK;
  });
}

FMI2_EXPORT fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], std::size_t nx) {
  return guarded(c, "fmi2GetContinuousStates", [&](Instance& in) {
    if (nx != in.x.size()) return in.fail("fmi2GetContinuousStates: wrong state count");
    std::copy(in.x.begin(), in.x.end(), x);
    return fmi2OK;
  });
}

FMI2_EXPORT fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real xdot[], std::size_t nx) {
  return guarded(c, "fmi2GetDerivatives", [&](Instance& in) {
    if (nx != in.x.size()) return in.fail("fmi2GetDerivatives: wrong state count");
    const fmi2Status s = eval_xdot(in);
    if (s == fmi2OK) std::copy(in.xdot.begin(), in.xdot.end(), xdot);
    return s;
  });
}

FMI2_EXPORT fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real[], std::size_t ni) {
  return guarded(c, "fmi2GetEventIndicators", [&](Instance& in) {
    return ni == 0 ? fmi2OK : in.fail("fmi2GetEventIndicators: the FMU has none");
  });
}

FMI2_EXPORT fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real nominals[],
                                                         std::size_t nx) {
  return guarded(c, "fmi2GetNominalsOfContinuousStates", [&](Instance& in) {
    if (nx != in.x.size()) return in.fail("fmi2GetNominalsOfContinuousStates: wrong count");
    for (std::size_t i = 0; i < nx; ++i) {  // as the description declares them
      const double tol = in.d->layout.states[i].abs_tol;
      nominals[i] = tol > 0.0 ? tol * 1e6 : 1.0;
    }
    return fmi2OK;
  });
}
