// The JSON spellings of the configuration enums, and the register count of each value type.
// Constant tables: any thread, no allocation.
#pragma once

#include <array>
#include <cstddef>
#include <string_view>

#include "config/config.hpp"

namespace hvac_twin::config {

inline constexpr std::array<std::string_view, 2> kRegisterKindNames{"holding", "input"};
inline constexpr std::array kRegisterKinds{RegisterKind::kHolding, RegisterKind::kInput};

inline constexpr std::array<std::string_view, 5> kValueTypeNames{"int16", "uint16", "int32",
                                                                 "uint32", "float32"};
inline constexpr std::array kValueTypes{ValueType::kInt16, ValueType::kUint16, ValueType::kInt32,
                                        ValueType::kUint32, ValueType::kFloat32};

inline constexpr std::array<std::string_view, 4> kWordOrderNames{"ABCD", "CDAB", "BADC", "DCBA"};
inline constexpr std::array kWordOrders{WordOrder::kABCD, WordOrder::kCDAB, WordOrder::kBADC,
                                        WordOrder::kDCBA};

inline constexpr std::array<std::string_view, 3> kPointRoleNames{"measured", "input",
                                                                 "disturbance"};
inline constexpr std::array kPointRoles{PointRole::kMeasured, PointRole::kInput,
                                        PointRole::kDisturbance};

inline constexpr std::array<std::string_view, 3> kEstimatorTypeNames{"ekf", "constrained_ekf",
                                                                     "constrained_enkf"};
inline constexpr std::array kEstimatorTypes{EstimatorType::kEkf, EstimatorType::kConstrainedEkf,
                                            EstimatorType::kConstrainedEnkf};

inline constexpr std::array<std::string_view, 5> kLogLevelNames{"trace", "debug", "info", "warn",
                                                                "error"};

// The tables above are indexed by the enum values.
static_assert(kRegisterKinds[1] == RegisterKind::kInput && kValueTypes[4] == ValueType::kFloat32 &&
              kWordOrders[3] == WordOrder::kDCBA && kPointRoles[2] == PointRole::kDisturbance &&
              kEstimatorTypes[2] == EstimatorType::kConstrainedEnkf);

constexpr std::string_view to_string(EstimatorType v) {
  return kEstimatorTypeNames[static_cast<std::size_t>(v)];
}
constexpr std::string_view to_string(RegisterKind v) {
  return kRegisterKindNames[static_cast<std::size_t>(v)];
}
constexpr std::string_view to_string(ValueType v) {
  return kValueTypeNames[static_cast<std::size_t>(v)];
}
constexpr std::string_view to_string(WordOrder v) {
  return kWordOrderNames[static_cast<std::size_t>(v)];
}
constexpr std::string_view to_string(PointRole v) {
  return kPointRoleNames[static_cast<std::size_t>(v)];
}

// 16-bit registers a value of type `t` occupies: 1 or 2.
constexpr int register_count(ValueType t) {
  return (t == ValueType::kInt16 || t == ValueType::kUint16) ? 1 : 2;
}

}  // namespace hvac_twin::config
