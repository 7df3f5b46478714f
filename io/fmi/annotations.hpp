// hvac-twin's FMI 2.0 tool annotations (`<Tool name="hvac-twin">`): what the daemon's filters
// take from a built-in model beyond FMI's own attributes, written into the FMUs it exports and
// read back by the import, so that an exported model runs in the daemon as the built-in one
// does. Other tools ignore them (FMI 2.0, 2.2.6); an FMU without them gets the import's
// defaults (fmu_model.hpp).
//
//   in a state's <ScalarVariable><Annotations>:
//     <State initialStd= processNoise= [augmented= consider= calibrate= heldWhileSettling=
//            persistent="true"] [reuseScale=] [excitedBy="<input name>" excitationMin=]/>
//   in an output's:
//     <Output modelError= modelErrorRel=/>
//   in <VendorAnnotations>, the constraints beyond the state bounds:
//     <Constraint name= over="states|outputs" bound= [whileInput= whileAbove=]>
//       <Term variable="<state or output name>" coefficient=/>...
//     </Constraint>
#pragma once

namespace hvac_twin::fmi {

inline constexpr const char* kToolName = "hvac-twin";

}  // namespace hvac_twin::fmi
