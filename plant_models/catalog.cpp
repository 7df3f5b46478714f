#include "plant_models/catalog.hpp"

#include <functional>
#include <stdexcept>
#include <string>

#include "plant_models/core/ad_model.hpp"
#include "plant_models/heat_pump/heat_pump.hpp"
#include "plant_models/zone/zone_rc.hpp"

namespace hvac_twin::plant {
namespace {

struct Entry {
  ModelSchema schema;
  std::function<std::unique_ptr<ContinuousModel>(const ParameterMap&)> create;
};

const std::vector<Entry>& entries() {
  static const std::vector<Entry> all{
      {{ZoneRc::kType,
        "lumped RC model of one zone: air and building-mass temperatures, internal gains "
        "estimated as a random walk",
        ZoneRc::parameter_info(), [](const ParameterMap&) { return ZoneRc::make_layout(); }},
       [](const ParameterMap& p) { return std::make_unique<AdModel<ZoneRc>>(ZoneRc(p)); }},
      {{HeatPumpR32::kType,
        "R32 split heat pump in cooling mode, finite-volume condenser and evaporator with N "
        "cells each, variable-speed compressor, expansion valve, and the zone it cools",
        HeatPumpR32::parameter_info(),
        [](const ParameterMap& p) { return HeatPumpR32(p).layout(); }},
       [](const ParameterMap& p) {
         return std::make_unique<AdModel<HeatPumpR32>>(HeatPumpR32(p));
       }},
  };
  return all;
}

const Entry* find_entry(std::string_view type) {
  for (const auto& e : entries())
    if (e.schema.type == type) return &e;
  return nullptr;
}

}  // namespace

const std::vector<ModelSchema>& model_schemas() {
  static const std::vector<ModelSchema> schemas = [] {
    std::vector<ModelSchema> out;
    for (const auto& e : entries())
      out.push_back(e.schema);
    return out;
  }();
  return schemas;
}

const ModelSchema* find_schema(std::string_view type) {
  const Entry* e = find_entry(type);
  return e == nullptr ? nullptr : &e->schema;
}

ParameterMap with_defaults(const ModelSchema& schema, const ParameterMap& params) {
  ParameterMap full = params;
  for (const auto& p : schema.parameters)
    full.try_emplace(p.name, p.default_value);
  return full;
}

std::unique_ptr<ContinuousModel> create_model(std::string_view type, const ParameterMap& params) {
  const Entry* e = find_entry(type);
  if (e == nullptr) throw std::invalid_argument("unknown model type \"" + std::string(type) + "\"");
  return e->create(with_defaults(e->schema, params));
}

}  // namespace hvac_twin::plant
