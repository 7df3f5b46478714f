// Readers for a unit's model and estimator sections: names and values checked against the
// model catalog.
#include <cmath>
#include <exception>
#include <unordered_set>

#include "config/detail/limits.hpp"
#include "config/detail/sections.hpp"
#include "config/enum_names.hpp"

namespace hvac_twin::config::detail {
namespace {

template <class Info>
std::vector<std::string> names_of(const std::vector<Info>& list) {
  std::vector<std::string> out;
  for (const auto& item : list)
    out.push_back(item.name);
  return out;
}

// unknown <what> "x" of model "m"; did you mean "y"? (expected one of "a", "b")
std::string unknown_name(std::string_view what, std::string_view name, std::string_view model,
                         const std::vector<std::string>& known) {
  std::string message = "unknown " + std::string(what) + " " + quote(name);
  if (!model.empty()) message += " of model " + quote(model);
  if (const auto guess = did_you_mean(name, known))
    message += "; did you mean " + quote(*guess) + "?";
  message +=
      known.empty() ? " (the model has none)" : " (expected one of " + quoted_list(known) + ")";
  return message;
}

// Calls `entry(name, value_ref)` for the first occurrence of every key of the object at `ref`
// (duplicates are reported elsewhere). Reports a non-object.
template <class Fn>
void for_each_entry(const Ref& ref, Errors& errors, Fn&& entry) {
  if (!ref.present()) return;
  if (!ref.node->is_object()) {
    errors.add(*ref.node, ref.pointer, "expected an object; got " + describe_value(*ref.node));
    return;
  }
  std::unordered_set<std::string_view> seen;
  for (const auto& m : ref.node->members) {
    if (!seen.insert(m.key).second) continue;
    entry(m.key, Ref{&m.value, child_pointer(ref.pointer, m.key)});
  }
}

bool read_parameter(const plant::ParameterInfo& info, const Ref& value, Errors& errors,
                    double& out) {
  const Node& n = *value.node;
  const Interval allowed = closed(info.min, info.max);
  const bool integral = n.is_number() && std::trunc(n.number) == n.number;
  if (n.is_number() && allowed.contains(n.number) && (!info.integer || integral)) {
    out = n.number;
    return true;
  }
  std::string expected = info.integer ? "an integer" : "a number";
  if (const std::string range = allowed.describe(); !range.empty()) expected += " " + range;
  if (!info.unit.empty()) expected += " [" + info.unit + "]";
  errors.add(n, value.pointer, "expected " + expected + "; got " + describe_value(n));
  return false;
}

// Upper bounds of a state's uncertainty: its square enters the covariance, and 1e308 squared
// was an infinite covariance (a numerical reset every cycle). A standard deviation wider than
// the state's range says nothing the bounds do not; a random walk that spans the range in an hour
// is as fast as any state drifts. A state without a finite range is capped at kMaxUnboundedStd.
double max_initial_std(const plant::StateInfo& s) {
  const double width = s.max - s.min;
  return std::isfinite(width) && width > 0.0 ? width : kMaxUnboundedStd;
}
double max_process_noise(const plant::StateInfo& s) {
  const double width = s.max - s.min;
  return std::isfinite(width) && width > 0.0 ? width / std::sqrt(kProcessNoiseSpanS)
                                             : kMaxUnboundedStd;
}

// "fmu": the file a model type with from_file() takes its model from (must be absolute: the
// daemon's working directory is not the configuration's), replacing the type's schema by the
// file's. Any other type has no file.
void read_model_file(ObjectReader& r, Errors& errors, ModelSection& out) {
  const Ref file = r.get("fmu");
  const bool wants_file = out.schema != nullptr && out.schema->from_file;
  if (!file.present()) {
    if (wants_file) {
      errors.add(*r.ref().node, r.ref().pointer,
                 "missing required field \"fmu\" (model type " + quote(out.schema->type) +
                     " takes its model from a file: the FMU's absolute path)");
      out.schema = nullptr;
    }
    return;
  }
  const auto path = read_string(file, errors);
  if (!path) {
    if (wants_file) out.schema = nullptr;
    return;
  }
  if (!wants_file) {
    if (out.schema != nullptr)
      errors.add(*file.node, file.pointer,
                 "model type " + quote(out.schema->type) + " is built in and takes no file");
    return;
  }
  out.schema = nullptr;
  if (path->empty() || path->front() != '/') {
    errors.add(*file.node, file.pointer, "expected the FMU's absolute path; got " + quote(*path));
    return;
  }
  try {
    out.file_schema =
        std::make_shared<const plant::ModelSchema>(out.catalog_schema->from_file(*path));
    out.schema = out.file_schema.get();
    out.config.file = *path;
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    errors.add(*file.node, file.pointer, e.what());
  }
}

}  // namespace

ModelSection read_model(const Ref& ref, Errors& errors, const ModelCatalog& models) {
  ModelSection out;
  ObjectReader r(ref, errors);
  if (const Ref type = r.require("type"); type.present()) {
    if (const auto name = read_string(type, errors)) {
      for (const auto& schema : models)
        if (schema.type == *name) out.schema = &schema;
      out.catalog_schema = out.schema;
      if (out.schema == nullptr) {
        std::vector<std::string> known;
        for (const auto& schema : models)
          known.push_back(schema.type);
        std::string message = "unknown model type " + quote(*name);
        if (const auto guess = did_you_mean(*name, known))
          message += "; did you mean " + quote(*guess) + "?";
        message += " (known types: " + quoted_list(known) + ")";
        errors.add(*type.node, type.pointer, std::move(message));
      } else {
        out.config.type = *name;
      }
    }
  }
  read_model_file(r, errors, out);
  // An invalid parameter takes its default for the layout, so that the points and estimator are
  // still checked, except an invalid integer (structural) parameter: the layout depends on it.
  bool structural_ok = true;
  const Ref parameters = r.get("parameters");
  for_each_entry(parameters, errors, [&](const std::string& name, const Ref& value) {
    double v = 0.0;
    if (out.schema == nullptr) {  // unknown type: at least check the values are numbers
      read_number(value, errors, any_finite());
      return;
    }
    const plant::ParameterInfo* info = nullptr;
    for (const auto& p : out.schema->parameters)
      if (p.name == name) info = &p;
    if (info == nullptr) {
      errors.add(
          *value.node, value.pointer,
          unknown_name("parameter", name, out.schema->type, names_of(out.schema->parameters)));
    } else if (read_parameter(*info, value, errors, v)) {
      out.config.parameters[name] = v;
    } else if (info->integer) {
      structural_ok = false;
    }
  });
  r.finish();

  if (out.schema == nullptr || !structural_ok || !out.schema->layout) return out;
  plant::ParameterMap full = out.config.parameters;
  for (const auto& p : out.schema->parameters)
    full.try_emplace(p.name, p.default_value);
  try {
    out.layout = out.schema->layout(full);
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    const Ref at = parameters.present() ? parameters : ref;
    errors.add(*at.node, at.pointer,
               "model " + quote(out.schema->type) + " rejected these parameters: " + e.what());
  }
  if (out.layout && (out.layout->states.size() > kMaxModelStates ||
                     out.layout->outputs.size() > kMaxModelOutputs)) {
    errors.add(*ref.node, ref.pointer,
               "the model has " + std::to_string(out.layout->states.size()) + " states and " +
                   std::to_string(out.layout->outputs.size()) + " outputs; at most " +
                   std::to_string(kMaxModelStates) + " and " + std::to_string(kMaxModelOutputs) +
                   " (the filters' matrices are dense)");
    out.layout.reset();
  }
  return out;
}

namespace {

void read_leak_detection(const Ref& ref, Errors& errors, LeakDetectionConfig& out) {
  if (!ref.present()) return;
  ObjectReader r(ref, errors);
  r.number("interval_s", out.interval_s, positive(kMaxPeriodS), false, "s");
  r.number("design_shift_sigma", out.design_shift_sigma, positive(100.0));
  r.number("false_alarm_interval_days", out.false_alarm_interval_days, positive(1e6), false,
           "days");
  r.number("warm_up_s", out.warm_up_s, closed(0.0, 30.0 * kMaxPeriodS), false, "s");
  r.number("startup_s", out.startup_s, closed(0.0, kMaxPeriodS), false, "s");
  r.number("min_compressor_speed_hz", out.min_compressor_speed_hz, closed(0.0, 1000.0), false,
           "Hz");
  r.number("max_starts_per_hour", out.max_starts_per_hour, positive(3600.0));
  r.number("leak_sigma_floor", out.leak_sigma_floor, closed(0.0, 1e4), false, "g/h");
  r.number("leak_rate_allowance", out.leak_rate_allowance, closed(0.0, 1e4), false, "g/h");
  r.number("charge_allowance", out.charge_allowance, closed(0.0, 1.0));
  r.number("charge_noise", out.charge_noise, closed(0.0, 1.0));
  r.number("reference_s", out.reference_s, positive(30.0 * kMaxPeriodS), false, "s");
  r.number("reference_band_hz", out.reference_band_hz, closed(1.0, 1000.0), false, "Hz");
  r.finish();
}

}  // namespace

EstimatorConfig read_estimator(const Ref& ref, Errors& errors, const EstimatorContext& context) {
  EstimatorConfig e;
  ObjectReader r(ref, errors);
  const bool period_ok = r.number("period_s", e.period_s, positive(kMaxPeriodS), false, "s");
  const bool deadline_ok =
      r.number("deadline_s", e.deadline_s, closed(kMinTickS, kMaxDeadlineS), false, "s");
  r.number("nis_gate", e.nis_gate, positive());
  r.number("robust_threshold", e.robust_threshold, at_least(0.0));
  r.integer("max_consecutive_rejections", e.max_consecutive_rejections, 1,
            kMaxConsecutiveRejections);
  r.number("settle_s", e.settle_s, closed(0.0, kMaxPeriodS), false, "s");
  r.number("parameter_hold_s", e.parameter_hold_s, closed(0.0, kMaxPeriodS), false, "s");
  r.number("parameter_release_s", e.parameter_release_s, closed(0.0, kMaxPeriodS), false, "s");
  r.choice("type", e.type, std::span<const std::string_view>(kEstimatorTypeNames),
           std::span<const EstimatorType>(kEstimatorTypes));
  r.integer("ensemble_members", e.ensemble_members, 4, 1000);
  r.integer("threads", e.threads, 1, 64);
  r.integer("checkpoint_every_cycles", e.checkpoint_every_cycles, 0, 1'000'000);
  r.number("checkpoint_max_age_s", e.checkpoint_max_age_s, closed(0.0, 3.2e7), false, "s");
  const bool window_ok = r.number("consistency_window_s", e.consistency_window_s,
                                  positive(30.0 * kMaxPeriodS), false, "s");
  r.number("adaptive_noise_min", e.adaptive_noise_min, closed(1e-2, 1.0));
  r.number("adaptive_noise_max", e.adaptive_noise_max, closed(1.0, 100.0));
  read_leak_detection(r.get("leak_detection"), errors, e.leak_detection);

  const plant::ModelLayout* layout = context.layout;
  const auto states = layout ? names_of(layout->states) : std::vector<std::string>{};
  // Reads one state -> value map; `allowed` gives the interval for a state (nullptr: unknown).
  const auto read_state_map = [&](std::string_view key, std::map<std::string, double>& out,
                                  auto allowed, std::string_view unit_suffix) {
    for_each_entry(r.get(key), errors, [&](const std::string& name, const Ref& value) {
      const plant::StateInfo* state = nullptr;
      if (layout != nullptr) {
        if (const auto i = layout->state(name)) state = &layout->states[*i];
        if (state == nullptr) {
          errors.add(*value.node, value.pointer,
                     unknown_name("state", name, context.model_type, states));
          return;
        }
      }
      const Interval interval = state ? allowed(*state) : any_finite();
      const std::string unit = state ? state->unit + std::string(unit_suffix) : std::string();
      if (const auto v = read_number(value, errors, interval, unit)) out[name] = *v;
    });
  };
  read_state_map(
      "process_noise", e.process_noise,
      [](const plant::StateInfo& s) { return closed(0.0, max_process_noise(s)); }, "/sqrt(s)");
  read_state_map(
      "initial_state", e.initial_state,
      [](const plant::StateInfo& s) { return closed(s.min, s.max); }, "");
  read_state_map(
      "initial_std", e.initial_std,
      [](const plant::StateInfo& s) { return positive(max_initial_std(s)); }, "");

  const Ref noise = r.require("measurement_noise");
  const auto outputs = layout ? names_of(layout->outputs) : std::vector<std::string>{};
  const PointsSection* points = context.points;
  for_each_entry(noise, errors, [&](const std::string& name, const Ref& value) {
    const plant::SignalInfo* output = nullptr;
    if (layout != nullptr) {
      if (const auto i = layout->output(name)) output = &layout->outputs[*i];
      if (output == nullptr) {
        errors.add(*value.node, value.pointer,
                   unknown_name("model output", name, context.model_type, outputs));
        return;
      }
      if (points != nullptr && points->complete && !points->measured.contains(name)) {
        errors.add(*value.node, value.pointer,
                   "output " + quote(name) +
                       " is not measured by any point of this unit; remove this entry or add a "
                       "point with role \"measured\" and signal " +
                       quote(name));
        return;
      }
    }
    if (const auto v = read_number(value, errors, positive(), output ? output->unit : ""))
      e.measurement_noise[name] = *v;
  });
  if (noise.present() && noise.node->is_object() && points != nullptr && layout != nullptr) {
    for (const auto& [output, point] : points->measured) {
      if (noise.node->find(output) != nullptr) continue;
      const auto i = layout->output(output);
      const std::string unit = i ? layout->outputs[*i].unit : std::string();
      errors.add(*noise.node, noise.pointer,
                 "missing entry for measured output " + quote(output) + " (measured by point " +
                     quote(point) + "); expected its standard deviation [" + unit + "], > 0");
    }
  }
  r.finish();

  if (!r.ok()) return e;  // cross-checks below report at the estimator object
  if (period_ok && context.time_scale) {
    const double wall_period = e.period_s / *context.time_scale;
    const bool wall_ok = closed(kMinTickS, kMaxWallPeriodS).contains(wall_period);
    if (!wall_ok) {
      const Ref at = r.get("period_s").present() ? r.get("period_s") : r.ref();
      errors.add(*at.node, at.pointer,
                 "the wall-clock period period_s / runtime.time_scale = " +
                     format_number(e.period_s) + " / " + format_number(*context.time_scale) +
                     " = " + format_number(wall_period) + " s; expected a number in [" +
                     format_number(kMinTickS) + ", " + format_number(kMaxWallPeriodS) +
                     "] s (the runtime counts it in whole nanoseconds, DDS takes at most 24 h)");
    }
    if (wall_ok && deadline_ok && e.deadline_s > wall_period) {
      const Ref at = r.get("deadline_s").present() ? r.get("deadline_s") : r.ref();
      errors.add(*at.node, at.pointer,
                 "deadline_s (" + format_number(e.deadline_s) +
                     " s) must not exceed the wall-clock period period_s / runtime.time_scale = " +
                     format_number(e.period_s) + " / " + format_number(*context.time_scale) +
                     " = " + format_number(wall_period) + " s");
    }
  }
  if (period_ok && window_ok &&
      !(std::round(e.consistency_window_s / e.period_s) <=
        static_cast<double>(kMaxConsistencyWindowCycles))) {
    const Ref given = r.get("consistency_window_s");
    const Ref at = given.present() ? given : r.ref();
    errors.add(*at.node, at.pointer,
               "consistency_window_s / period_s = " + format_number(e.consistency_window_s) +
                   " / " + format_number(e.period_s) + " = " +
                   format_number(std::round(e.consistency_window_s / e.period_s)) +
                   " cycles; expected at most " + std::to_string(kMaxConsistencyWindowCycles) +
                   " (the window is held in memory per measured point): shorten "
                   "consistency_window_s or lengthen period_s");
  }
  if (deadline_ok && context.hang_timeout_s && !(e.deadline_s < *context.hang_timeout_s)) {
    const Ref at = r.get("deadline_s").present() ? r.get("deadline_s") : r.ref();
    errors.add(*at.node, at.pointer,
               "deadline_s (" + format_number(e.deadline_s) +
                   " s) must be below runtime.hang_timeout_s (" +
                   format_number(*context.hang_timeout_s) + " s)");
  }
  return e;
}

}  // namespace hvac_twin::config::detail
