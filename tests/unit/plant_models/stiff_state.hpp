// A state the leak benchmark's filter reached at 21 h of scenarios (b) and (f) (leak_bench
// --trace-dir, its failure dump) with the valve factor estimated as well (stiff_structure(): the
// demo's structure and the valve, 65 states; recorded before the end-wall states, so without
// them):
// the compressor just started at 20 Hz, the valve at 0.41, the evaporator's first cells left
// colder than the one downstream of them by an update. Its linearisation has modes growing at
// 1e10 per second and modes decaying as fast, so F is far from orthogonal: the matrix
// exponential of a segment can overflow (exponential_fallback_test.cpp), and F P F' loses
// positive definiteness to rounding (tests/unit/estimation/stiff_predict_test.cpp).
#pragma once

#include <vector>

#include "tests/unit/plant_models/heat_pump_fixture.hpp"

namespace hvac_twin::test {

inline plant::ParameterMap stiff_structure() {
  plant::ParameterMap p = demo_structure();
  p["augment_valve_factor"] = 1.0;
  p["end_walls"] = 0.0;
  return p;
}

inline const std::vector<double> kStiffState{
    0.50280945315172176, 0.46861393639324639, 578.01064575714554,  511.30347440186011,
    488.15924830437001,  464.68178635545905,  439.77061742614092,  407.64692621693388,
    356.80505000877235,  301.28693004227148,  270.42929637814899,  260.84648658768174,
    258.54404341502374,  256.36303438755539,  253.66530954874546,  259.59536843338475,
    290.27081571534973,  321.69596678947823,  318.72921282968849,  541.82552016131672,
    536.56998497230018,  539.47464528370961,  538.3992526204712,   538.57858557152576,
    538.53412899111038,  538.42178756937176,  538.54007420955065,  538.49857802819395,
    538.16951423048658,  25.771132191117108,  1.0489007471544798,  0.97947625269121641,
    0.99753987994007398, 0.81247607933723542, 0.81304772697544503, 1.0995646279295284,
    32.112519508009655,  28.258131315274294,  28.209692466482135,  28.145349780280174,
    28.048552970589309,  27.900358943764548,  27.716786784557971,  27.565979221435871,
    27.485958274440573,  27.445247986160041,  27.408301689537861,  27.368057522019217,
    9.4011027814005068,  9.159147342922731,   7.6159574118164022,  17.800593528249827,
    26.05987479705783,   25.673607987616823,  25.695129857445931,  25.545451081139937,
    25.590810833433935,  25.499401071703463,  25.545227439984785,  25.534812507732052,
    25.405786771104029,  682.84263309580956,  3.1277967629493868,  0.9891547020785002,
    1.0157476186025258,
};
inline const std::vector<double> kStiffInputs{20, 0.41239431021439732, 0.69999999999999996,
                                              0.59999999999999998, 24.806030612657796};

}  // namespace hvac_twin::test
