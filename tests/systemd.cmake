# tests/systemd.cmake: CTest registration of the systemd unit check.
# Included from the top-level CMakeLists.txt after enable_testing() and after
# the daemon's targets (it uses the built hapticd if the target exists).
if(NOT DEFINED HAPTICD_GENERATED_UNIT)
  include(${CMAKE_CURRENT_LIST_DIR}/../systemd/install.cmake)
endif()
find_program(HAPTICD_SYSTEMD_ANALYZE systemd-analyze)
if(NOT HAPTICD_SYSTEMD_ANALYZE)
  message(STATUS "systemd-analyze not found: systemd_unit_verify is not registered")
  return()
endif()
if(TARGET hapticd)
  set(_hapticd_verify_binary $<TARGET_FILE:hapticd>)
else()
  set(_hapticd_verify_binary "")  # the script makes a dummy executable
endif()
add_test(NAME systemd_unit_verify
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_verify.sh ${HAPTICD_GENERATED_UNIT} "${_hapticd_verify_binary}")
# The same check on a copy with a misspelt key must fail: proves the check
# does not pass on warnings.
add_test(NAME systemd_unit_verify_detects_typo
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_verify.sh ${HAPTICD_GENERATED_UNIT} "${_hapticd_verify_binary}"
                 --inject-typo)
# The template for several devices on one machine, and its typo check.
add_test(NAME systemd_template_unit_verify
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_verify.sh ${HAPTICD_GENERATED_TEMPLATE_UNIT} "${_hapticd_verify_binary}")
add_test(NAME systemd_template_unit_verify_detects_typo
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_verify.sh ${HAPTICD_GENERATED_TEMPLATE_UNIT} "${_hapticd_verify_binary}"
                 --inject-typo)
# Issue 17: `systemd-analyze security --offline=yes` exposure at most 2.0,
# for each unit alone and with each per-driver drop-in (systemd/drivers/),
# verify clean for each; and the same check on a unit stripped of its
# sandboxing must see it over 2.0 (the check can fail).
set(HAPTICD_MAX_EXPOSURE 2.0)
add_test(NAME systemd_unit_security
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_security.sh ${HAPTICD_GENERATED_UNIT} ${HAPTICD_DROPIN_SOURCE_DIR}
                 ${HAPTICD_MAX_EXPOSURE})
add_test(NAME systemd_template_unit_security
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_security.sh ${HAPTICD_GENERATED_TEMPLATE_UNIT}
                 ${HAPTICD_DROPIN_SOURCE_DIR} ${HAPTICD_MAX_EXPOSURE})
add_test(NAME systemd_unit_security_detects_loosening
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_security.sh ${HAPTICD_GENERATED_UNIT} ${HAPTICD_DROPIN_SOURCE_DIR}
                 ${HAPTICD_MAX_EXPOSURE} --loosened)
set_tests_properties(systemd_unit_verify systemd_unit_verify_detects_typo systemd_template_unit_verify
                     systemd_template_unit_verify_detects_typo systemd_unit_security systemd_template_unit_security
                     systemd_unit_security_detects_loosening PROPERTIES LABELS systemd)
set_tests_properties(systemd_unit_verify_detects_typo systemd_template_unit_verify_detects_typo
                     PROPERTIES WILL_FAIL TRUE)

# The sysusers.d entry parses and creates the hapticd user and group
# (dry run in an empty root; warnings fail the test).
find_program(HAPTICD_SYSTEMD_SYSUSERS systemd-sysusers)
if(HAPTICD_SYSTEMD_SYSUSERS)
  add_test(NAME systemd_sysusers_dry_run
           COMMAND sh -c "r=$(mktemp -d) && mkdir -p \"$r/etc\" && \"$1\" --dry-run --root=\"$r\" \"$2\" 2>&1; s=$?; rm -rf \"$r\"; exit $s"
                   sh ${HAPTICD_SYSTEMD_SYSUSERS} ${CMAKE_CURRENT_LIST_DIR}/../systemd/hapticd.sysusers)
  set_tests_properties(systemd_sysusers_dry_run PROPERTIES LABELS systemd
    PASS_REGULAR_EXPRESSION "Creating user 'hapticd' \\(hapticd daemon\\)"
    FAIL_REGULAR_EXPRESSION "[Ii]gnoring|[Ff]ailed|[Ii]nvalid")
endif()
