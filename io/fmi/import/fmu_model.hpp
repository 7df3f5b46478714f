// An FMI 2.0 Model Exchange FMU as a plant model: the same ContinuousModel interface the built-in
// models implement, so the integrator, the filters, checkpoints and virtual sensors run on it
// unchanged.
//
//   states       the <Derivatives> of ModelStructure and the variables they are derivatives of;
//                min/max become the state bounds of the constrained update; the initial
//                estimate is the state the FMU's initialisation computed (fmi2GetContinuousStates;
//                the description's start values for configuration validation), its default sigma
//                0.1 max(|start|, nominal)
//   inputs       causality "input" (start: the default when no point provides one)
//   outputs      causality "output", in <Outputs> order
//   parameters   causality "parameter" (Real), set before initialisation from a ParameterMap
//   disturbances augment_<input> = 1: a random-walk state added to that input (below)
//
// The model is autonomous (ContinuousModel has no time): an FMU whose equations read `time`
// sees 0. Jacobians: fmi2GetDirectionalDerivative, one state direction per call, when the FMU
// provides it; otherwise central differences, step cbrt(eps) max(|x_j|, nominal_j) (2n
// evaluations). jacobian_method() says which.
//
// Errors: fmi2Discard is recoverable (kModelRecoverable: the integrator retries smaller);
// fmi2Error and fmi2Fatal are fatal, and the instance is not called again (every later call
// returns kModelFatal); failure() holds the FMU's last logged message. In-process isolation
// only: an FMU that crashes or corrupts memory takes the process with it.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "io/fmi/fmi2.hpp"
#include "io/fmi/import/model_description.hpp"
#include "plant_models/core/model.hpp"

namespace hvac_twin::fmi {

// An unpacked, loaded FMU: its description and its shared library. Shared by the instances.
class FmuLibrary;

enum class JacobianMethod { kDirectionalDerivative, kFiniteDifferences };

struct FmuOptions {
  plant::ParameterMap parameters;   // by variable name; each must be a Real parameter
  bool finite_differences = false;  // even when the FMU provides directional derivatives
  std::string instance_name = "hvac-twin";
};

// Unpacks `fmu_path` into `unpack_directory`, parses and checks its description, and loads
// binaries/linux64/<modelIdentifier>.so. Start-up only; throws FmuError.
std::shared_ptr<const FmuLibrary> load_fmu(const std::string& fmu_path,
                                           const std::string& unpack_directory);

const ModelDescription& description_of(const FmuLibrary& library);

// Input disturbances: parameter "augment_<input>" = 1 (not the FMU's own; the schema offers one
// per input) appends a random-walk state "<input>_disturbance" added to that input, as the
// built-in models' augment_ parameters append theirs (FMI 2.0 fixes an FMU's parameters at its
// initialisation, so an unknown the filter should track is an input or one of the FMU's states).
inline constexpr const char* kAugmentPrefix = "augment_";
inline constexpr const char* kDisturbanceSuffix = "_disturbance";

// The indices (into the description's inputs) `params` augments, in input order.
std::vector<std::size_t> fmu_disturbances(const ModelDescription& description,
                                          const plant::ParameterMap& params);

// The layout an FMU's description gives with `params` (above; a variable without a unit has
// unit "1"): the FMU's states, then the disturbances.
plant::ModelLayout fmu_layout(const ModelDescription& description,
                              const plant::ParameterMap& params);

class FmuModel final : public plant::ContinuousModel {
 public:
  // Instantiates and initialises the FMU. Throws FmuError (unknown parameter, refused instance).
  FmuModel(std::shared_ptr<const FmuLibrary> library, FmuOptions options);
  ~FmuModel() override;

  [[nodiscard]] const plant::ModelLayout& layout() const override { return layout_; }
  int rhs(std::span<const double> x, std::span<const double> u,
          std::span<double> xdot) const override;
  int rhs_jacobian(std::span<const double> x, std::span<const double> u, std::span<double> xdot,
                   std::span<double> jac) const override;
  int outputs(std::span<const double> x, std::span<const double> u,
              std::span<double> y) const override;
  int output_jacobian(std::span<const double> x, std::span<const double> u, std::span<double> y,
                      std::span<double> jac) const override;
  [[nodiscard]] std::unique_ptr<plant::ContinuousModel> clone() const override;
  [[nodiscard]] const char* failure() const override {
    return failed_ ? last_error_.c_str() : nullptr;
  }

  [[nodiscard]] JacobianMethod jacobian_method() const { return method_; }

 private:
  static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                     fmi2String category, fmi2String message, ...);
  int status(fmi2Status s, const char* call) const;
  int set(std::span<const double> x, std::span<const double> u) const;
  int eval(bool outputs, std::span<const double> x, std::span<const double> u,
           std::span<double> out) const;
  int jacobian(bool outputs, std::span<const double> x, std::span<const double> u,
               std::span<double> value, std::span<double> jac) const;

  std::shared_ptr<const FmuLibrary> lib_;
  FmuOptions options_;
  plant::ModelLayout layout_;
  JacobianMethod method_;
  std::vector<fmi2ValueReference> state_refs_, derivative_refs_, input_refs_, output_refs_;
  std::vector<double> nominal_;              // per state, the disturbances' 1
  std::vector<std::size_t> disturbed_;       // per disturbance state, its input
  mutable std::vector<double> u_effective_;  // the inputs plus their disturbances
  fmi2CallbackFunctions callbacks_{};
  fmi2Component component_ = nullptr;
  mutable std::vector<double> x_try_, f_plus_, f_minus_;
  mutable std::string last_error_;
  mutable bool failed_ = false;
};

}  // namespace hvac_twin::fmi
