// hvac-twin-fmu-describe TYPE FILE [STRUCTURE]: writes the modelDescription.xml of the built-in
// model TYPE exported as an FMI 2.0 Model Exchange FMU, its structural parameters as STRUCTURE
// sets them (describe_builtin; the build packages it with the FMU's library, built with the same).
#include <cstdio>
#include <exception>
#include <fstream>

#include "io/fmi/export/fmu_description.hpp"

int main(int argc, char** argv) {
  if (argc != 3 && argc != 4) {
    std::fprintf(stderr, "usage: %s MODEL_TYPE OUTPUT_FILE [NAME=VALUE,...]\n", argv[0]);
    return 2;
  }
  try {
    const auto m = hvac_twin::fmi::describe_builtin(argv[1], argc == 4 ? argv[3] : "");
    std::ofstream out(argv[2], std::ios::binary | std::ios::trunc);
    out << m.xml;
    out.close();
    if (!out) {
      std::fprintf(stderr, "%s: cannot write %s\n", argv[0], argv[2]);
      return 1;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", argv[0], e.what());
    return 1;
  }
  return 0;
}
