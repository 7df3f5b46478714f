// Reader for one unit: its device, model, points and estimator, in the order their checks
// depend on each other (model before points before estimator), whatever the document order.
#include "config/detail/limits.hpp"
#include "config/detail/sections.hpp"

namespace hvac_twin::config::detail {

UnitConfig read_unit(const Ref& ref, Errors& errors, const UnitContext& context) {
  UnitConfig u;
  ObjectReader r(ref, errors);
  if (const Ref id = r.require("id"); id.present()) {
    if (auto v = read_token(id, errors, is_id_char, "[A-Za-z0-9_-]", kMaxNameLength)) u.id = *v;
  }
  const ModbusSection modbus = read_modbus(r.get("modbus"), errors);
  u.modbus = modbus.config;

  ModelSection model = read_model(r.require("model"), errors, context.models);
  u.model = std::move(model.config);
  const plant::ModelLayout* layout = model.layout ? &*model.layout : nullptr;

  PointContext point_context{layout, u.model.type, modbus.poll_period_s};
  PointsSection points = read_points(r.require("points"), errors, point_context);

  EstimatorContext estimator_context{layout, u.model.type, &points, context.time_scale,
                                     context.hang_timeout_s};
  u.estimator = read_estimator(r.require("estimator"), errors, estimator_context);
  u.points = std::move(points.points);
  r.string("calibration", u.calibration);
  r.finish();

  if (modbus.max_registers.present() && u.modbus.max_registers_per_request < 2 &&
      !points.two_register_point.empty())
    errors.add(*modbus.max_registers.node, modbus.max_registers.pointer,
               "max_registers_per_request must be at least 2: point " +
                   quote(points.two_register_point) + " is a 2-register value");
  return u;
}

}  // namespace hvac_twin::config::detail
