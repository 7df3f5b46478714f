// hvac-twind: the hvac-twin estimation daemon.
#include "daemon/runtime/daemon_main.hpp"

int main(int argc, char** argv) {
  return hvac_twin::runtime::daemon_main(argc, argv, nullptr);
}
