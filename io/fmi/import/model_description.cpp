#include "io/fmi/import/model_description.hpp"

#include <cerrno>
#include <cstdlib>
#include <map>
#include <pugixml.hpp>

#include "io/fmi/annotations.hpp"

namespace hvac_twin::fmi {
namespace {

[[noreturn]] void fail(const std::string& source, const std::string& what) {
  throw FmuError(source + ": " + what);
}

double number_attr(const pugi::xml_node& node, const char* name, double fallback,
                   const std::string& source, const std::string& variable) {
  const pugi::xml_attribute a = node.attribute(name);
  if (!a) return fallback;
  const char* text = a.value();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || errno == ERANGE)
    fail(source,
         "variable \"" + variable + "\": attribute " + name + "=\"" + text + "\" is not a number");
  return v;
}

unsigned long index_attr(const pugi::xml_node& node, std::size_t count, const std::string& source,
                         const char* where) {
  const unsigned long long i = node.attribute("index").as_ullong(0);
  if (i == 0 || i > count)
    fail(source, std::string("<") + where + "> <Unknown index=\"" +
                     node.attribute("index").value() + "\"> is not a variable (1.." +
                     std::to_string(count) + ")");
  return static_cast<unsigned long>(i - 1);
}

}  // namespace

ModelDescription parse_model_description(const std::string& text, const std::string& source) {
  pugi::xml_document doc;
  const pugi::xml_parse_result parsed = doc.load_buffer(text.data(), text.size());
  if (!parsed)
    fail(source, std::string("not well-formed XML (") + parsed.description() + " at byte " +
                     std::to_string(parsed.offset) + ")");
  const pugi::xml_node root = doc.child("fmiModelDescription");
  if (!root) fail(source, "no <fmiModelDescription> element");
  const std::string version = root.attribute("fmiVersion").value();
  if (version != "2.0")
    fail(source, "fmiVersion is \"" + version + "\"; only FMI 2.0 is supported");
  ModelDescription d;
  d.model_name = root.attribute("modelName").value();
  d.guid = root.attribute("guid").value();
  if (d.guid.empty()) fail(source, "<fmiModelDescription> has no guid");
  const pugi::xml_node me = root.child("ModelExchange");
  if (!me)
    fail(source,
         "not a Model Exchange FMU (no <ModelExchange>; Co-Simulation FMUs are not "
         "supported)");
  d.model_identifier = me.attribute("modelIdentifier").value();
  if (d.model_identifier.empty() || d.model_identifier.find_first_of("/\\") != std::string::npos ||
      d.model_identifier == ".." || d.model_identifier == ".")
    fail(source,
         "<ModelExchange> modelIdentifier \"" + d.model_identifier + "\" is not a file name");
  d.provides_directional_derivative = me.attribute("providesDirectionalDerivative").as_bool(false);
  const long indicators = root.attribute("numberOfEventIndicators").as_llong(0);
  if (indicators != 0)
    fail(source, "the model has " + std::to_string(indicators) +
                     " event indicators; FMUs with state events are not supported");

  // Units of declared types, for variables that take theirs from a <SimpleType>.
  std::map<std::string, std::string> type_units;
  for (const pugi::xml_node t : root.child("TypeDefinitions").children("SimpleType"))
    type_units[t.attribute("name").value()] = t.child("Real").attribute("unit").value();

  for (const pugi::xml_node sv : root.child("ModelVariables").children("ScalarVariable")) {
    FmuVariable v;
    v.name = sv.attribute("name").value();
    if (!sv.attribute("valueReference"))
      fail(source, "variable \"" + v.name + "\" has no valueReference");
    v.ref = sv.attribute("valueReference").as_uint();
    if (sv.attribute("causality")) v.causality = sv.attribute("causality").value();
    if (sv.attribute("variability")) v.variability = sv.attribute("variability").value();
    v.description = sv.attribute("description").value();
    const pugi::xml_node type = sv.first_child();
    v.type = type ? type.name() : "";
    if (v.type == "Real") {
      v.unit = type.attribute("unit").value();
      if (v.unit.empty() && type.attribute("declaredType"))
        v.unit = type_units[type.attribute("declaredType").value()];
      v.start = number_attr(type, "start", v.start, source, v.name);
      v.min = number_attr(type, "min", v.min, source, v.name);
      v.max = number_attr(type, "max", v.max, source, v.name);
      v.nominal = number_attr(type, "nominal", v.nominal, source, v.name);
      if (type.attribute("derivative"))
        v.derivative_of = static_cast<long>(type.attribute("derivative").as_llong(0)) - 1;
    }
    for (const pugi::xml_node tool : sv.child("Annotations").children("Tool")) {
      if (std::string(tool.attribute("name").value()) != kToolName) continue;
      for (const pugi::xml_attribute a : tool.first_child().attributes())
        v.tool[a.name()] = a.value();
    }
    const bool io = v.causality == "input" || v.causality == "output";
    if (io && v.type != "Real")
      fail(source, "variable \"" + v.name + "\" is an " + v.causality + " of type " + v.type +
                       "; only Real inputs and outputs are supported");
    if (v.variability == "discrete" && v.causality != "input")
      fail(source,
           "variable \"" + v.name + "\" is discrete; FMUs with discrete states are not supported");
    d.variables.push_back(std::move(v));
  }
  for (const pugi::xml_node tool : root.child("VendorAnnotations").children("Tool")) {
    if (std::string(tool.attribute("name").value()) != kToolName) continue;
    for (const pugi::xml_node c : tool.children("Constraint")) {
      ToolConstraint t;
      t.name = c.attribute("name").value();
      t.over_outputs = std::string(c.attribute("over").value()) == "outputs";
      t.bound = number_attr(c, "bound", 0.0, source, t.name);
      t.while_input = c.attribute("whileInput").value();
      t.while_above = number_attr(c, "whileAbove", 0.0, source, t.name);
      for (const pugi::xml_node term : c.children("Term"))
        t.terms.emplace_back(term.attribute("variable").value(),
                             number_attr(term, "coefficient", 0.0, source, t.name));
      d.constraints.push_back(std::move(t));
    }
  }
  const std::size_t count = d.variables.size();
  for (std::size_t i = 0; i < count; ++i) {
    const FmuVariable& v = d.variables[i];
    if (v.causality == "input") d.inputs.push_back(i);
    if (v.causality == "parameter" && v.type == "Real") d.parameters.push_back(i);
  }
  const pugi::xml_node structure = root.child("ModelStructure");
  for (const pugi::xml_node u : structure.child("Outputs").children("Unknown"))
    d.outputs.push_back(index_attr(u, count, source, "Outputs"));
  for (const pugi::xml_node u : structure.child("Derivatives").children("Unknown")) {
    const std::size_t i = index_attr(u, count, source, "Derivatives");
    const FmuVariable& der = d.variables[i];
    if (der.derivative_of < 0 || static_cast<std::size_t>(der.derivative_of) >= count)
      fail(source, "derivative \"" + der.name + "\" does not name its state (derivative=)");
    const auto state = static_cast<std::size_t>(der.derivative_of);
    if (d.variables[state].type != "Real")
      fail(source, "state \"" + d.variables[state].name + "\" is not Real");
    d.derivatives.push_back(i);
    d.states.push_back(state);
  }
  for (std::size_t i : d.outputs)
    if (d.variables[i].causality != "output")
      fail(source, "<Outputs> lists \"" + d.variables[i].name + "\", whose causality is " +
                       d.variables[i].causality);
  return d;
}

}  // namespace hvac_twin::fmi
