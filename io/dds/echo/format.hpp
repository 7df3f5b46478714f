// How hvac-twin-echo prints a sample: one JSON object, or one aligned human-readable line.
// Pure functions (no I/O); they allocate the returned string.
#pragma once

#include <string>

#include "io/dds/subscriber.hpp"

namespace hvac_twin::dds::echo {

// One JSON object without a trailing newline: {"topic":"virtual_sensor", then every wire field
// in IDL order}. Enums are strings ("GOOD"), flags a number plus "flag_names":[...].
std::string to_json_line(const Record& record);

// One line without a trailing newline, e.g.
//   12:00:05 hp1      zone_air_temperature              21.43 ± 0.05     degC     GOOD
// Time is the sample's timestamp in local time. Decimals follow the 1-sigma uncertainty.
std::string to_text_line(const Record& record);

}  // namespace hvac_twin::dds::echo
