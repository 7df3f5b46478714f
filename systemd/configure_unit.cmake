# Writes UNIT_OUTPUT: the unit UNIT_SOURCE with its ExecStart= binary in SBINDIR and its
# Documentation= in DOCDIR (absolute paths) instead of /usr/sbin and /usr/share/doc/hvac_twin.
# Used by the install rule of systemd/CMakeLists.txt.
file(READ "${UNIT_SOURCE}" _unit)
foreach(_expected "ExecStart=/usr/sbin/hvac-twind " "file:///usr/share/doc/hvac_twin/")
  string(FIND "${_unit}" "${_expected}" _at)
  if(_at EQUAL -1)
    message(FATAL_ERROR "${UNIT_SOURCE}: no '${_expected}' to rewrite")
  endif()
endforeach()
string(REPLACE "ExecStart=/usr/sbin/hvac-twind " "ExecStart=${SBINDIR}/hvac-twind " _unit
               "${_unit}")
string(REPLACE "file:///usr/share/doc/hvac_twin/" "file://${DOCDIR}/" _unit "${_unit}")
file(WRITE "${UNIT_OUTPUT}" "${_unit}")
