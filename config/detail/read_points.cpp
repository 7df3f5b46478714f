// Reader for a unit's points: each point's fields, its model signal and unit, and the rules
// between points (unique names, no overlapping registers, every required model input fed once).
#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "config/detail/limits.hpp"
#include "config/detail/sections.hpp"
#include "config/enum_names.hpp"
#include "config/units.hpp"

namespace hvac_twin::config::detail {
namespace {

struct PointResult {
  PointConfig config;
  bool address_ok = false;
  bool type_ok = false;
  bool kind_ok = false;
  bool name_ok = false;
  bool role_ok = false;
  bool feeds_ok = false;  // role and signal valid (and the signal exists when it can be checked)
  Ref name;
  Ref address;
  Ref signal;
};

// The first point of each register of each kind, filled in point order: the earlier points a
// point overlaps are the owners of its registers, found in O(1) (was a pairwise O(n^2) scan).
class RegisterOwners {
 public:
  // The first point owning one of `p`'s registers (`index` if none), then claims the free ones.
  std::size_t claim(const PointConfig& p, std::size_t index) {
    auto& owner = owners_[static_cast<std::size_t>(p.kind)];
    if (owner.empty()) owner.assign(kRegisters, kFree);
    std::size_t first = index;
    const auto begin = static_cast<std::size_t>(p.address);
    for (std::size_t a = begin; a < begin + static_cast<std::size_t>(register_count(p.type)); ++a) {
      if (owner[a] == kFree)
        owner[a] = index;
      else
        first = std::min(first, owner[a]);
    }
    return first;
  }

 private:
  static constexpr std::size_t kRegisters = 65536;
  static constexpr std::size_t kFree = static_cast<std::size_t>(-1);
  std::array<std::vector<std::size_t>, std::size(kRegisterKinds)> owners_;
};

std::vector<std::string> signal_names(const std::vector<plant::SignalInfo>& list) {
  std::vector<std::string> out;
  for (const auto& s : list)
    out.push_back(s.name);
  return out;
}

std::string register_span(const PointConfig& p) {
  const int n = register_count(p.type);
  const std::string first = std::to_string(p.address);
  return std::string(to_string(p.kind)) +
         (n == 1 ? " register " + first
                 : " registers " + first + "-" + std::to_string(p.address + n - 1));
}

// Checks the point's signal against the model; returns the signal's info when it resolves.
const plant::SignalInfo* resolve_signal(const PointResult& p, Errors& errors,
                                        const PointContext& context) {
  const plant::ModelLayout& layout = *context.layout;
  const bool measured = p.config.role == PointRole::kMeasured;
  const auto& own = measured ? layout.outputs : layout.inputs;
  const auto& other = measured ? layout.inputs : layout.outputs;
  const char* own_kind = measured ? "model output" : "model input";
  if (const auto i = plant::ModelLayout::find(own, p.config.signal)) return &own[*i];
  const auto names = signal_names(own);
  std::string message;
  if (plant::ModelLayout::find(other, p.config.signal)) {
    message = quote(p.config.signal) + " is a " + (measured ? "model input" : "model output") +
              "; a point with role " + quote(to_string(p.config.role)) + " must name a " +
              own_kind + " of model " + quote(context.model_type) + ": " + quoted_list(names);
  } else {
    message = "unknown " + std::string(own_kind) + " " + quote(p.config.signal) + " of model " +
              quote(context.model_type);
    if (const auto guess = did_you_mean(p.config.signal, names))
      message += "; did you mean " + quote(*guess) + "?";
    message += " (expected one of " + quoted_list(names) + ")";
  }
  errors.add(*p.signal.node, p.signal.pointer, std::move(message));
  return nullptr;
}

void read_range(ObjectReader& r, PointConfig& p) {
  Errors& errors = r.errors();
  const Ref range = r.require("range");
  if (!range.present()) return;
  const Node& n = *range.node;
  if (!n.is_array() || n.elements.size() != 2) {
    errors.add(n, range.pointer,
               "expected [min, max], two numbers with min < max; got " + describe_value(n) +
                   (n.is_array() ? " of " + std::to_string(n.elements.size()) + " elements" : ""));
    return;
  }
  const auto lo = read_number(range.at(std::size_t{0}), errors, any_finite());
  const auto hi = read_number(range.at(std::size_t{1}), errors, any_finite());
  if (!lo || !hi) return;
  if (!(*lo < *hi)) {
    errors.add(n, range.pointer,
               "expected [min, max] with min < max; got [" + n.elements[0].text + ", " +
                   n.elements[1].text + "]");
    return;
  }
  p.range_min = *lo;
  p.range_max = *hi;
}

PointResult read_point(const Ref& ref, Errors& errors, const PointContext& context) {
  PointResult out;
  PointConfig& p = out.config;
  ObjectReader r(ref, errors);
  out.name = r.require("name");
  if (out.name.present()) {
    if (auto v = read_token(out.name, errors, is_identifier_char, "[A-Za-z0-9_]", kMaxNameLength)) {
      p.name = *v;
      out.name_ok = true;
    }
  }
  out.kind_ok = r.choice<RegisterKind>("register", p.kind, kRegisterKindNames, kRegisterKinds);
  out.address_ok = r.integer("address", p.address, 0, 65535, /*required=*/true);
  out.address = r.get("address");
  out.type_ok = r.choice<ValueType>("type", p.type, kValueTypeNames, kValueTypes);
  const bool order_ok =
      r.choice<WordOrder>("word_order", p.word_order, kWordOrderNames, kWordOrders);
  if (const Ref scale = r.get("scale"); scale.present()) {
    const Node& n = *scale.node;
    if (n.is_number() && n.number != 0.0)
      p.scale = n.number;
    else
      errors.add(n, scale.pointer, "expected a non-zero number; got " + describe_value(n));
  }
  r.number("offset", p.offset, any_finite());
  const Ref unit = r.require("unit");
  bool unit_ok = false;
  if (unit.present()) {
    if (const auto v = read_string(unit, errors)) {
      unit_ok = find_unit(*v) != nullptr;
      if (unit_ok) {
        p.unit = *v;
      } else {
        std::vector<std::string> known;
        for (const auto& u : known_units())
          known.emplace_back(u.name);
        std::string message = "unknown unit " + quote(*v);
        if (const auto guess = did_you_mean(*v, known))
          message += "; did you mean " + quote(*guess) + "?";
        message += " (known units: " + quoted_list(known) + ")";
        errors.add(*unit.node, unit.pointer, std::move(message));
      }
    }
  }
  read_range(r, p);
  const bool stale_ok =
      r.number("stale_after_s", p.stale_after_s, positive(kMaxStaleAfterS), false, "s");
  r.number("stuck_after_s", p.stuck_after_s, closed(0.0, kMaxStuckAfterS), false, "s");
  out.role_ok = r.choice<PointRole>("role", p.role, kPointRoleNames, kPointRoles);
  out.signal = r.require("signal");
  bool signal_ok = false;
  if (out.signal.present()) {
    if (const auto v = read_string(out.signal, errors)) {
      p.signal = *v;
      signal_ok = true;
    }
  }
  r.finish();
  if (!r.ok()) return out;

  // Rules between the fields of this point.
  const int registers = register_count(p.type);
  if (out.type_ok && order_ok && registers == 1 && p.word_order != WordOrder::kABCD &&
      p.word_order != WordOrder::kBADC) {
    const Ref at = r.get("word_order");
    errors.add(*at.node, at.pointer,
               quote(to_string(p.word_order)) + " is not a byte order of a 16-bit value (type " +
                   quote(to_string(p.type)) + "); expected \"ABCD\" or \"BADC\"");
  }
  if (out.address_ok && out.type_ok && p.address + registers - 1 > 65535) {
    errors.add(*out.address.node, out.address.pointer,
               "a " + std::to_string(registers) + "-register " + quote(to_string(p.type)) +
                   " value at address " + std::to_string(p.address) +
                   " runs past the last register (65535)");
    out.address_ok = false;
  }
  if (stale_ok && context.poll_period_s && !(p.stale_after_s > *context.poll_period_s)) {
    const Ref field = r.get("stale_after_s");
    const Ref at = field.present() ? field : ref;
    errors.add(*at.node, at.pointer,
               "stale_after_s (" + format_number(p.stale_after_s) +
                   " s) must exceed the unit's modbus poll_period_s (" +
                   format_number(*context.poll_period_s) +
                   " s), or the point turns STALE between polls");
  }
  out.feeds_ok = out.role_ok && signal_ok;
  if (out.feeds_ok && context.layout != nullptr) {
    const plant::SignalInfo* signal = resolve_signal(out, errors, context);
    out.feeds_ok = signal != nullptr;
    if (signal != nullptr && unit_ok && !conversion(p.unit, signal->unit)) {
      errors.add(*unit.node, unit.pointer,
                 "unit " + quote(p.unit) + " cannot be converted to " + quote(signal->unit) +
                     ", the unit of " +
                     (p.role == PointRole::kMeasured ? "model output " : "model input ") +
                     quote(signal->name));
    }
  }
  return out;
}

}  // namespace

PointsSection read_points(const Ref& ref, Errors& errors, const PointContext& context) {
  PointsSection out;
  if (!ref.present()) {  // reported by the caller
    out.complete = false;
    return out;
  }
  if (!ref.node->is_array() || ref.node->elements.empty()) {
    errors.add(*ref.node, ref.pointer,
               "expected a non-empty array of points; got " + describe_value(*ref.node));
    out.complete = false;
    return out;
  }
  std::vector<PointResult> results;
  for (std::size_t i = 0; i < ref.node->elements.size(); ++i)
    results.push_back(read_point(ref.at(i), errors, context));

  std::map<std::string, std::string> fed_by;                      // model input -> point name
  std::unordered_map<std::string_view, std::size_t> first_named;  // name -> first point
  RegisterOwners owners;
  std::size_t measured = 0;
  for (std::size_t i = 0; i < results.size(); ++i) {
    const PointResult& p = results[i];
    const PointConfig& c = p.config;
    if (p.name_ok) {
      if (const auto [it, first] = first_named.try_emplace(c.name, i); !first)
        errors.add(*p.name.node, p.name.pointer,
                   "duplicate point name " + quote(c.name) + "; also the name of " +
                       child_pointer(ref.pointer, it->second));
    }
    if (p.address_ok && p.type_ok && p.kind_ok) {
      if (const auto j = owners.claim(c, i); j < i) {
        const PointConfig& q = results[j].config;
        errors.add(*p.address.node, p.address.pointer,
                   register_span(c) + " overlap " + register_span(q) + " of point " +
                       quote(q.name) + " (" + child_pointer(ref.pointer, j) + ")");
      }
    }
    if (p.role_ok && c.role == PointRole::kMeasured) ++measured;
    if (!p.feeds_ok) {
      out.complete = false;
    } else if (c.role == PointRole::kMeasured) {
      out.measured.try_emplace(c.signal, c.name);
    } else if (const auto [it, inserted] = fed_by.try_emplace(c.signal, c.name); !inserted) {
      errors.add(*p.signal.node, p.signal.pointer,
                 "model input " + quote(c.signal) + " is already fed by point " +
                     quote(it->second) + "; each model input takes exactly one point");
    }
    if (p.type_ok && register_count(c.type) == 2 && out.two_register_point.empty())
      out.two_register_point = c.name.empty() ? child_pointer(ref.pointer, i) : c.name;
  }
  out.points.reserve(results.size());
  for (auto& p : results)
    out.points.push_back(std::move(p.config));

  if (measured > kMaxMeasuredPoints)
    errors.add(*ref.node, ref.pointer,
               std::to_string(measured) + " points have role \"measured\"; a unit takes at most " +
                   std::to_string(kMaxMeasuredPoints) +
                   " (the points fused in a cycle are published as a 64-bit mask)");
  if (context.layout == nullptr || !out.complete) return out;
  for (const auto& input : context.layout->inputs) {
    if (!std::isnan(input.default_value) || fed_by.contains(input.name)) continue;
    errors.add(*ref.node, ref.pointer,
               "model input " + quote(input.name) + " [" + input.unit + "] of model " +
                   quote(context.model_type) +
                   " has no default and no point feeds it; add a point with role \"input\" or "
                   "\"disturbance\" and signal " +
                   quote(input.name));
  }
  if (out.measured.empty())
    errors.add(*ref.node, ref.pointer,
               "no point has role \"measured\"; the estimator needs at least one measurement");
  return out;
}

}  // namespace hvac_twin::config::detail
