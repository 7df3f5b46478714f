#include "io/fmi/export/fmu_description.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "io/fmi/annotations.hpp"
#include "plant_models/catalog.hpp"

namespace hvac_twin::fmi {
namespace {

std::string number(double v) {
  std::array<char, 32> buf{};
  const auto r = std::to_chars(buf.data(), buf.data() + buf.size(), v);  // shortest round trip
  return std::string(buf.data(), r.ptr);
}

std::string escaped(std::string_view s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// SI base-unit exponents (kg, m, s, K) with factor and offset: value_SI = factor * value + offset.
struct UnitDef {
  const char* name;
  int kg, m, s, K;
  double factor, offset;
};
constexpr std::array<UnitDef, 18> kUnits{{
    {"K", 0, 0, 0, 1, 1.0, 0.0},
    {"degC", 0, 0, 0, 1, 1.0, 273.15},
    {"W", 1, 2, -3, 0, 1.0, 0.0},
    {"kW", 1, 2, -3, 0, 1e3, 0.0},
    {"Pa", 1, -1, -2, 0, 1.0, 0.0},
    {"kPa", 1, -1, -2, 0, 1e3, 0.0},
    {"MPa", 1, -1, -2, 0, 1e6, 0.0},
    {"bar", 1, -1, -2, 0, 1e5, 0.0},
    {"J/K", 1, 2, -2, -1, 1.0, 0.0},
    {"W/K", 1, 2, -3, -1, 1.0, 0.0},
    {"J/kg", 0, 2, -2, 0, 1.0, 0.0},
    {"kJ/kg", 0, 2, -2, 0, 1e3, 0.0},
    {"kg", 1, 0, 0, 0, 1.0, 0.0},
    {"kg/s", 1, 0, -1, 0, 1.0, 0.0},
    {"m2", 0, 2, 0, 0, 1.0, 0.0},
    {"m3", 0, 3, 0, 0, 1.0, 0.0},
    {"s", 0, 0, 1, 0, 1.0, 0.0},
    {"Hz", 0, 0, -1, 0, 1.0, 0.0},
}};

void unit_definition(std::string& x, const std::string& unit) {
  x += "    <Unit name=\"" + escaped(unit) + "\">";
  for (const auto& d : kUnits) {
    if (unit != d.name) continue;
    x += "<BaseUnit";
    const auto exp = [&](const char* a, int e) {
      if (e != 0) x += std::string(" ") + a + "=\"" + std::to_string(e) + "\"";
    };
    exp("kg", d.kg);
    exp("m", d.m);
    exp("s", d.s);
    exp("K", d.K);
    if (d.factor != 1.0) x += " factor=\"" + number(d.factor) + "\"";
    if (d.offset != 0.0) x += " offset=\"" + number(d.offset) + "\"";
    x += "/>";
  }
  x += "</Unit>\n";
}

std::string range(double lo, double hi) {
  std::string out;
  if (std::isfinite(lo)) out += " min=\"" + number(lo) + "\"";
  if (std::isfinite(hi)) out += " max=\"" + number(hi) + "\"";
  return out;
}

// FMI scales an importer's tolerances by a state's nominal value (absolute tolerance = relative
// tolerance x nominal): the nominal that gives the model's own absolute tolerance at the
// daemon's relative tolerance, 1e-6.
std::string nominal(double abs_tol) {
  return abs_tol > 0.0 ? " nominal=\"" + number(abs_tol * 1e6) + "\"" : std::string();
}

std::string unit_attr(const std::string& unit) {
  return unit.empty() || unit == "1" ? std::string() : " unit=\"" + escaped(unit) + "\"";
}

// `tool`: the attributes of an hvac-twin annotation element (`<State .../>`), or empty.
void variable(std::string& x, const std::string& name, unsigned ref, const char* attrs,
              const std::string& description, const std::string& real,
              const std::string& tool = {}) {
  x += "    <ScalarVariable name=\"" + escaped(name) + "\" valueReference=\"" +
       std::to_string(ref) + "\" " + attrs;
  if (!description.empty()) x += " description=\"" + escaped(description) + "\"";
  x += ">\n      <Real" + real + "/>\n";
  if (!tool.empty())
    x += "      <Annotations><Tool name=\"" + std::string(kToolName) + "\">" + tool +
         "</Tool></Annotations>\n";
  x += "    </ScalarVariable>\n";
}

std::string flag(const char* name, bool value) {
  return value ? std::string(" ") + name + "=\"true\"" : std::string();
}

// What the daemon's filters take from a state beyond FMI's own attributes (io/fmi/annotations.hpp).
std::string state_annotation(const plant::ModelLayout& l, const plant::StateInfo& s) {
  std::string a = "<State initialStd=\"" + number(s.initial_std) + "\" processNoise=\"" +
                  number(s.process_noise) + "\"" + flag("augmented", s.augmented) +
                  flag("consider", s.consider) + flag("calibrate", s.calibrate) +
                  flag("heldWhileSettling", s.held_while_settling) +
                  flag("persistent", s.persistent);
  if (s.reuse_scale > 0.0) a += " reuseScale=\"" + number(s.reuse_scale) + "\"";
  if (s.excited_by >= 0 && static_cast<std::size_t>(s.excited_by) < l.inputs.size())
    a += " excitedBy=\"" + escaped(l.inputs[static_cast<std::size_t>(s.excited_by)].name) +
         "\" excitationMin=\"" + number(s.excitation_min) + "\"";
  return a + "/>";
}

std::string output_annotation(const plant::SignalInfo& s) {
  if (s.model_error == 0.0 && s.model_error_rel == 0.0) return {};
  return "<Output modelError=\"" + number(s.model_error) + "\" modelErrorRel=\"" +
         number(s.model_error_rel) + "\"/>";
}

// The constraints beyond the state bounds, their terms by variable name.
void constraints(std::string& x, const plant::ModelLayout& l) {
  if (l.constraints.empty()) return;
  x += "  <VendorAnnotations>\n    <Tool name=\"" + std::string(kToolName) + "\">\n";
  for (const auto& c : l.constraints) {
    const bool outputs = c.over == plant::LinearConstraint::Over::kOutputs;
    x += "      <Constraint name=\"" + escaped(c.name) + "\" over=\"" +
         (outputs ? "outputs" : "states") + "\" bound=\"" + number(c.bound) + "\"";
    if (c.while_input >= 0 && static_cast<std::size_t>(c.while_input) < l.inputs.size())
      x += " whileInput=\"" + escaped(l.inputs[static_cast<std::size_t>(c.while_input)].name) +
           "\" whileAbove=\"" + number(c.while_above) + "\"";
    x += ">";
    for (const auto& [index, coefficient] : c.terms)
      x += "<Term variable=\"" +
           escaped(outputs ? l.outputs.at(index).name : l.states.at(index).name) +
           "\" coefficient=\"" + number(coefficient) + "\"/>";
    x += "</Constraint>\n";
  }
  x += "    </Tool>\n  </VendorAnnotations>\n";
}

// An input must have a start value (FMI 2.0, 2.2.7); one the model has no default for starts at
// zero moved into its range.
double input_start(const plant::SignalInfo& s) {
  if (!std::isnan(s.default_value)) return s.default_value;
  return std::fmin(std::fmax(0.0, s.min), s.max);
}

std::uint64_t fnv1a(std::string_view s, std::uint64_t h) {
  for (unsigned char c : s) {
    h ^= c;
    h *= 0x100000001b3ULL;
  }
  return h;
}

std::string guid_of(std::string_view text) {
  const std::uint64_t a = fnv1a(text, 0xcbf29ce484222325ULL);
  const std::uint64_t b = fnv1a(text, a ^ 0x9e3779b97f4a7c15ULL);
  std::array<char, 40> buf{};
  const auto hex = [](std::uint64_t v, int digits, char* out) {
    for (int i = digits - 1; i >= 0; --i, v >>= 4)
      out[i] = "0123456789abcdef"[v & 0xF];
  };
  char* p = buf.data();
  *p++ = '{';
  hex(a >> 32, 8, p), p += 8, *p++ = '-';
  hex(a >> 16, 4, p), p += 4, *p++ = '-';
  hex(a, 4, p), p += 4, *p++ = '-';
  hex(b >> 48, 4, p), p += 4, *p++ = '-';
  hex(b, 12, p), p += 12, *p++ = '}';
  return std::string(buf.data(), p);
}

std::string description_xml(const ExportedModel& m, const std::string& guid) {
  const plant::ModelLayout& l = m.layout;
  std::string x = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  x += "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"" + escaped(m.type) + "\" guid=\"" +
       guid + "\" description=\"" + escaped(m.description) +
       "\" generationTool=\"hvac-twin\" variableNamingConvention=\"flat\" "
       "numberOfEventIndicators=\"0\">\n";
  x += "  <ModelExchange modelIdentifier=\"" + escaped(m.type) +
       "\" providesDirectionalDerivative=\"true\" completedIntegratorStepNotNeeded=\"true\" "
       "canNotUseMemoryManagementFunctions=\"true\" canGetAndSetFMUstate=\"false\"/>\n";
  std::vector<std::string> units;
  const auto add_unit = [&](const std::string& u) {
    if (u.empty() || u == "1") return;
    for (const auto& v : units)
      if (v == u) return;
    units.push_back(u);
  };
  for (const auto& s : l.states)
    add_unit(s.unit);
  for (const auto& s : l.inputs)
    add_unit(s.unit);
  for (const auto& s : l.outputs)
    add_unit(s.unit);
  for (const auto& p : m.tunable)
    add_unit(p.unit);
  for (const auto& p : m.structural)
    add_unit(p.unit);
  x += "  <UnitDefinitions>\n";
  for (const auto& u : units)
    unit_definition(x, u);
  x += "  </UnitDefinitions>\n";
  constraints(x, l);
  x += "  <ModelVariables>\n";
  for (std::size_t i = 0; i < m.n(); ++i) {
    const auto& s = l.states[i];
    variable(x, s.name, m.state_ref(i),
             "causality=\"local\" variability=\"continuous\" initial=\"exact\"", s.description,
             unit_attr(s.unit) + range(s.min, s.max) + nominal(s.abs_tol) + " start=\"" +
                 number(s.initial) + "\"",
             state_annotation(l, s));
  }
  for (std::size_t i = 0; i < m.n(); ++i) {
    const auto& s = l.states[i];
    variable(x, "der(" + s.name + ")", m.derivative_ref(i),
             "causality=\"local\" variability=\"continuous\"", "",
             " derivative=\"" + std::to_string(i + 1) + "\"");
  }
  for (std::size_t i = 0; i < l.inputs.size(); ++i) {
    const auto& s = l.inputs[i];
    variable(x, s.name, m.input_ref(i), "causality=\"input\" variability=\"continuous\"",
             s.description,
             unit_attr(s.unit) + range(s.min, s.max) + " start=\"" + number(input_start(s)) + "\"");
  }
  for (std::size_t i = 0; i < l.outputs.size(); ++i) {
    const auto& s = l.outputs[i];
    variable(x, s.name, m.output_ref(i), "causality=\"output\" variability=\"continuous\"",
             s.description, unit_attr(s.unit) + range(s.min, s.max), output_annotation(s));
  }
  std::size_t k = 0;
  for (const auto& p : m.tunable)
    variable(
        x, p.name, m.parameter_ref(k++),
        "causality=\"parameter\" variability=\"fixed\" initial=\"exact\"", p.description,
        unit_attr(p.unit) + range(p.min, p.max) + " start=\"" + number(p.default_value) + "\"");
  for (const auto& p : m.structural)
    variable(x, p.name, m.parameter_ref(k++),
             "causality=\"local\" variability=\"constant\" initial=\"exact\"",
             p.description + " (structural: fixed when the FMU was built)",
             unit_attr(p.unit) + " start=\"" + number(p.default_value) + "\"");
  x += "  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n";
  for (std::size_t i = 0; i < l.outputs.size(); ++i)
    x += "      <Unknown index=\"" + std::to_string(m.output_ref(i) + 1) + "\"/>\n";
  x += "    </Outputs>\n    <Derivatives>\n";
  for (std::size_t i = 0; i < m.n(); ++i)
    x += "      <Unknown index=\"" + std::to_string(m.derivative_ref(i) + 1) + "\"/>\n";
  x += "    </Derivatives>\n    <InitialUnknowns>\n";  // ascending index: derivatives, outputs
  for (std::size_t i = 0; i < m.n(); ++i)
    x += "      <Unknown index=\"" + std::to_string(m.derivative_ref(i) + 1) + "\"/>\n";
  for (std::size_t i = 0; i < l.outputs.size(); ++i)
    x += "      <Unknown index=\"" + std::to_string(m.output_ref(i) + 1) + "\"/>\n";
  x += "    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n";
  return x;
}

}  // namespace

ExportedModel describe_builtin(std::string_view type, std::string_view structure) {
  const plant::ModelSchema* schema = plant::find_schema(type);
  if (schema == nullptr)
    throw std::invalid_argument("unknown model type \"" + std::string(type) + "\"");
  ExportedModel m;
  m.type = schema->type;
  m.description = schema->description;
  for (const auto& p : schema->parameters)
    (p.integer ? m.structural : m.tunable).push_back(p);
  plant::ParameterMap built;
  while (!structure.empty()) {
    const auto comma = structure.find(',');
    const std::string_view item = structure.substr(0, comma);
    structure = comma == std::string_view::npos ? std::string_view{} : structure.substr(comma + 1);
    const auto eq = item.find('=');
    const std::string name(item.substr(0, eq));
    plant::ParameterInfo* p = nullptr;
    for (auto& s : m.structural)
      if (s.name == name) p = &s;
    double value = 0.0;
    if (eq == std::string_view::npos || p == nullptr ||
        std::from_chars(item.data() + eq + 1, item.data() + item.size(), value).ptr !=
            item.data() + item.size() ||
        !(value >= p->min && value <= p->max))
      throw std::invalid_argument("structure \"" + std::string(item) +
                                  "\": not a structural parameter of " + m.type +
                                  " with a value in its range");
    p->default_value = value;
    built[name] = value;
  }
  m.layout = schema->layout(plant::with_defaults(*schema, built));
  // The GUID hashes the text it is written into, with a placeholder in its place.
  m.guid = guid_of(description_xml(m, "{}"));
  m.xml = description_xml(m, m.guid);
  return m;
}

}  // namespace hvac_twin::fmi
