// The FMI 2.0 C API, declared here from the standard's text (Functional Mock-up Interface for
// Model Exchange and Co-Simulation, version 2.0, chapter 2 "Common Concepts" and chapter 3
// "FMI for Model Exchange"): types, status codes, callbacks and the signatures of the functions
// an FMU's shared library exports under their plain names (fmi2GetReal, ...). Only what Model
// Exchange uses; no third-party FMI header is involved (none is packaged by Debian).
#pragma once

#include <cstddef>

extern "C" {

using fmi2Component = void*;
using fmi2ComponentEnvironment = void*;
using fmi2FMUstate = void*;
using fmi2ValueReference = unsigned int;
using fmi2Real = double;
using fmi2Integer = int;
using fmi2Boolean = int;
using fmi2Char = char;
using fmi2String = const fmi2Char*;
using fmi2Byte = char;

inline constexpr fmi2Boolean fmi2True = 1;
inline constexpr fmi2Boolean fmi2False = 0;

enum fmi2Status { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending };
enum fmi2Type { fmi2ModelExchange, fmi2CoSimulation };

// The message is a printf format, the arguments follow it.
using fmi2CallbackLogger = void (*)(fmi2ComponentEnvironment, fmi2String instance_name, fmi2Status,
                                    fmi2String category, fmi2String message, ...);
using fmi2CallbackAllocateMemory = void* (*)(std::size_t count, std::size_t size);
using fmi2CallbackFreeMemory = void (*)(void*);
using fmi2StepFinished = void (*)(fmi2ComponentEnvironment, fmi2Status);

struct fmi2CallbackFunctions {
  fmi2CallbackLogger logger;
  fmi2CallbackAllocateMemory allocateMemory;
  fmi2CallbackFreeMemory freeMemory;
  fmi2StepFinished stepFinished;
  fmi2ComponentEnvironment componentEnvironment;
};

struct fmi2EventInfo {
  fmi2Boolean newDiscreteStatesNeeded;
  fmi2Boolean terminateSimulation;
  fmi2Boolean nominalsOfContinuousStatesChanged;
  fmi2Boolean valuesOfContinuousStatesChanged;
  fmi2Boolean nextEventTimeDefined;
  fmi2Real nextEventTime;
};

// Function types, named as the standard names them (fmi2<Name>TYPE).
using fmi2GetTypesPlatformTYPE = const char* (*)();
using fmi2GetVersionTYPE = const char* (*)();
using fmi2SetDebugLoggingTYPE = fmi2Status (*)(fmi2Component, fmi2Boolean logging_on,
                                               std::size_t n_categories,
                                               const fmi2String categories[]);
using fmi2InstantiateTYPE = fmi2Component (*)(fmi2String instance_name, fmi2Type, fmi2String guid,
                                              fmi2String resource_location,
                                              const fmi2CallbackFunctions*, fmi2Boolean visible,
                                              fmi2Boolean logging_on);
using fmi2FreeInstanceTYPE = void (*)(fmi2Component);
using fmi2SetupExperimentTYPE = fmi2Status (*)(fmi2Component, fmi2Boolean tolerance_defined,
                                               fmi2Real tolerance, fmi2Real start_time,
                                               fmi2Boolean stop_time_defined, fmi2Real stop_time);
using fmi2EnterInitializationModeTYPE = fmi2Status (*)(fmi2Component);
using fmi2ExitInitializationModeTYPE = fmi2Status (*)(fmi2Component);
using fmi2TerminateTYPE = fmi2Status (*)(fmi2Component);
using fmi2ResetTYPE = fmi2Status (*)(fmi2Component);
using fmi2GetRealTYPE = fmi2Status (*)(fmi2Component, const fmi2ValueReference[], std::size_t,
                                       fmi2Real[]);
using fmi2SetRealTYPE = fmi2Status (*)(fmi2Component, const fmi2ValueReference[], std::size_t,
                                       const fmi2Real[]);
using fmi2GetDirectionalDerivativeTYPE = fmi2Status (*)(fmi2Component,
                                                        const fmi2ValueReference unknowns[],
                                                        std::size_t n_unknown,
                                                        const fmi2ValueReference knowns[],
                                                        std::size_t n_known, const fmi2Real seed[],
                                                        fmi2Real sensitivity[]);
// Model Exchange.
using fmi2EnterEventModeTYPE = fmi2Status (*)(fmi2Component);
using fmi2NewDiscreteStatesTYPE = fmi2Status (*)(fmi2Component, fmi2EventInfo*);
using fmi2EnterContinuousTimeModeTYPE = fmi2Status (*)(fmi2Component);
using fmi2CompletedIntegratorStepTYPE = fmi2Status (*)(fmi2Component,
                                                       fmi2Boolean no_set_state_prior,
                                                       fmi2Boolean* enter_event_mode,
                                                       fmi2Boolean* terminate_simulation);
using fmi2SetTimeTYPE = fmi2Status (*)(fmi2Component, fmi2Real time);
using fmi2SetContinuousStatesTYPE = fmi2Status (*)(fmi2Component, const fmi2Real x[],
                                                   std::size_t nx);
using fmi2GetDerivativesTYPE = fmi2Status (*)(fmi2Component, fmi2Real derivatives[],
                                              std::size_t nx);
using fmi2GetEventIndicatorsTYPE = fmi2Status (*)(fmi2Component, fmi2Real indicators[],
                                                  std::size_t ni);
using fmi2GetContinuousStatesTYPE = fmi2Status (*)(fmi2Component, fmi2Real x[], std::size_t nx);
using fmi2GetNominalsOfContinuousStatesTYPE = fmi2Status (*)(fmi2Component, fmi2Real nominals[],
                                                             std::size_t nx);

}  // extern "C"
