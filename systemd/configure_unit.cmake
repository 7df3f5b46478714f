# Writes UNIT_OUTPUT: the unit UNIT_SOURCE with its ExecStart= binary EXEC_NAME (found in
# EXEC_FROM, /usr/sbin or /usr/bin) in EXEC_DIR and its Documentation= in DOCDIR (absolute paths)
# instead of /usr/share/doc/hvac_twin. Used by the install rules of systemd/CMakeLists.txt.
file(READ "${UNIT_SOURCE}" _unit)
foreach(_expected "ExecStart=${EXEC_FROM}/${EXEC_NAME} " "file:///usr/share/doc/hvac_twin/")
  string(FIND "${_unit}" "${_expected}" _at)
  if(_at EQUAL -1)
    message(FATAL_ERROR "${UNIT_SOURCE}: no '${_expected}' to rewrite")
  endif()
endforeach()
string(REPLACE "ExecStart=${EXEC_FROM}/${EXEC_NAME} " "ExecStart=${EXEC_DIR}/${EXEC_NAME} " _unit
               "${_unit}")
string(REPLACE "file:///usr/share/doc/hvac_twin/" "file://${DOCDIR}/" _unit "${_unit}")
file(WRITE "${UNIT_OUTPUT}" "${_unit}")
