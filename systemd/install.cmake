# systemd/install.cmake: install rules for the systemd unit, the sysusers.d
# entry and the configuration. Included from the top-level CMakeLists.txt
# (after GNUInstallDirs and the daemon's targets).
include_guard(GLOBAL)
include(GNUInstallDirs)

set(HAPTICD_CONFIG_DIR "/etc/hapticd" CACHE PATH
    "Directory of hapticd.toml (the unit's --config points here)")
set(HAPTICD_SYSTEMD_UNIT_DIR "${CMAKE_INSTALL_PREFIX}/lib/systemd/system" CACHE PATH
    "Where hapticd.service is installed (systemd also reads /usr/local/lib/systemd/system)")
set(HAPTICD_SYSUSERS_DIR "${CMAKE_INSTALL_PREFIX}/lib/sysusers.d" CACHE PATH
    "Where the sysusers.d entry is installed")

set(HAPTICD_BINARY "${CMAKE_INSTALL_FULL_BINDIR}/hapticd")
set(HAPTICD_DOC_DIR "${CMAKE_INSTALL_FULL_DOCDIR}")
# The per-driver drop-ins (systemd/drivers/README.md), for the administrator
# to copy into /etc/systemd/system/<unit>.d/.
set(HAPTICD_DROPIN_DIR "${CMAKE_INSTALL_FULL_DATADIR}/hapticd/systemd")
set(HAPTICD_DROPIN_SOURCE_DIR "${CMAKE_CURRENT_LIST_DIR}/drivers")
# One source, two units: the plain unit for one device and the template
# hapticd@.service for several devices on one machine (%i names the
# instance: its config file, socket directory and recording directory).
set(HAPTICD_GENERATED_UNIT "${PROJECT_BINARY_DIR}/systemd/hapticd.service")
set(HAPTICD_UNIT_DESCRIPTION "hapticd real-time haptics daemon")
set(HAPTICD_CONFIG_NAME "hapticd")
set(HAPTICD_INSTANCE_DIRECTORY "hapticd")
set(HAPTICD_UNIT_NAME "hapticd.service")
configure_file(${CMAKE_CURRENT_LIST_DIR}/hapticd.service.in ${HAPTICD_GENERATED_UNIT} @ONLY)
set(HAPTICD_GENERATED_TEMPLATE_UNIT "${PROJECT_BINARY_DIR}/systemd/hapticd@.service")
set(HAPTICD_UNIT_DESCRIPTION "hapticd real-time haptics daemon, device %i")
set(HAPTICD_CONFIG_NAME "%i")
set(HAPTICD_INSTANCE_DIRECTORY "hapticd/%i")
set(HAPTICD_UNIT_NAME "hapticd@NAME.service")
configure_file(${CMAKE_CURRENT_LIST_DIR}/hapticd.service.in ${HAPTICD_GENERATED_TEMPLATE_UNIT} @ONLY)

install(FILES ${HAPTICD_GENERATED_UNIT} ${HAPTICD_GENERATED_TEMPLATE_UNIT} DESTINATION ${HAPTICD_SYSTEMD_UNIT_DIR}
        COMPONENT systemd)
file(GLOB _hapticd_dropins ${HAPTICD_DROPIN_SOURCE_DIR}/*.conf)
install(FILES ${_hapticd_dropins} ${HAPTICD_DROPIN_SOURCE_DIR}/README.md DESTINATION ${HAPTICD_DROPIN_DIR}
        COMPONENT systemd)
install(FILES ${CMAKE_CURRENT_LIST_DIR}/hapticd.sysusers DESTINATION ${HAPTICD_SYSUSERS_DIR}
        RENAME hapticd.conf COMPONENT systemd)

# The installed configuration: never overwrite a file the administrator edited.
set(_hapticd_config_src "${CMAKE_CURRENT_LIST_DIR}/../config/hapticd.toml")
install(CODE "
  # file(INSTALL) prefixes DESTDIR itself; only the existence check needs it.
  set(_dest \"\$ENV{DESTDIR}${HAPTICD_CONFIG_DIR}\")
  if(EXISTS \"\${_dest}/hapticd.toml\")
    message(STATUS \"Keeping existing: \${_dest}/hapticd.toml\")
  else()
    file(INSTALL \"${_hapticd_config_src}\" DESTINATION \"${HAPTICD_CONFIG_DIR}\" FILE_PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ)
  endif()
" COMPONENT config)
# Every example, for reference (with the docs: <prefix>/share/doc/hapticd/examples).
file(GLOB _hapticd_examples ${CMAKE_CURRENT_LIST_DIR}/../config/*.toml)
install(FILES ${_hapticd_examples} DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples COMPONENT config)
install(FILES ${CMAKE_CURRENT_LIST_DIR}/../docs/config.md DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT config OPTIONAL)

# issue 23: device permissions. The udev rules give the hapticd group the
# devices the daemon drives (docs/config.md, "Device permissions"); the CAN interface's
# systemd-networkd example goes with the other examples.
set(HAPTICD_UDEV_RULES_DIR "${CMAKE_INSTALL_PREFIX}/lib/udev/rules.d" CACHE PATH
    "Where the udev rules are installed (udev also reads /usr/local/lib/udev/rules.d and /etc/udev/rules.d)")
file(GLOB _hapticd_udev_rules ${CMAKE_CURRENT_LIST_DIR}/../config/*.rules)
install(FILES ${_hapticd_udev_rules} DESTINATION ${HAPTICD_UDEV_RULES_DIR} COMPONENT udev)
install(FILES ${CMAKE_CURRENT_LIST_DIR}/../config/80-hapticd-can.network
        DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples/networkd COMPONENT config)
