# The estimation core and the plant models are pure libraries (design.md): no Modbus, DDS,
# logging, clock, thread or stream I/O header may appear in them. Run as
#   cmake -DSOURCE_DIR=<repo> -P tests/layering_check.cmake
# Fails listing every offending include.
set(pure_dirs plant_models daemon/estimation)
set(forbidden
  "modbus" "dds/" "dds\\.h" "spdlog" "systemd" "<chrono>" "<thread>" "<ctime>" "<time\\.h>"
  "<iostream>" "<fstream>" "<cstdio>" "<stdio\\.h>" "io/" "daemon/runtime" "config/")
set(violations "")
foreach(dir IN LISTS pure_dirs)
  file(GLOB_RECURSE files "${SOURCE_DIR}/${dir}/*.hpp" "${SOURCE_DIR}/${dir}/*.cpp")
  foreach(f IN LISTS files)
    file(STRINGS "${f}" includes REGEX "^[ \t]*#[ \t]*include")
    foreach(line IN LISTS includes)
      foreach(pattern IN LISTS forbidden)
        if(line MATCHES "${pattern}")
          # The CVODES error handler formats into a fixed buffer with snprintf: no I/O.
          if(f MATCHES "core/integrator\\.cpp$" AND pattern STREQUAL "<cstdio>")
            continue()
          endif()
          # The ensemble filter spreads its members over its own worker threads.
          if(f MATCHES "estimation/worker_pool\\.(hpp|cpp)$" AND pattern STREQUAL "<thread>")
            continue()
          endif()
          file(RELATIVE_PATH rel "${SOURCE_DIR}" "${f}")
          list(APPEND violations "${rel}: ${line}")
        endif()
      endforeach()
    endforeach()
  endforeach()
endforeach()
if(violations)
  list(JOIN violations "\n  " text)
  message(FATAL_ERROR "pure libraries include I/O, clock or middleware headers:\n  ${text}")
endif()
message(STATUS "layering: plant_models and daemon/estimation include no I/O headers")
