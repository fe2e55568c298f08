# The Debian package of a rig PC (`cpack -G DEB` in a build folder): the
# kcrig binary, the default configuration (the model, the rig, the DBC and
# the Modbus map) in share/kcrig/config, where the binary looks beside
# itself, and the manual in share/doc/kcrig. Its run-time dependencies are
# the shared libraries the binary links, found by dpkg-shlibdeps.
# Installing and packaging take the kcrig target as built, never the whole
# tree's (tests, benchmarks): build kcrig first.
set(CMAKE_SKIP_INSTALL_ALL_DEPENDENCY ON)
install(DIRECTORY config/ DESTINATION ${CMAKE_INSTALL_DATADIR}/kcrig/config)
install(FILES README.md DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(DIRECTORY docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR}/docs)
# The folders' READMEs the manual links to.
file(GLOB folder_readmes RELATIVE ${PROJECT_SOURCE_DIR}
  ${PROJECT_SOURCE_DIR}/*/README.md)
foreach(readme ${folder_readmes})
  get_filename_component(folder ${readme} DIRECTORY)
  install(FILES ${readme} DESTINATION ${CMAKE_INSTALL_DOCDIR}/${folder})
endforeach()

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME kcrig)
set(CPACK_PACKAGE_VENDOR kcrig)
set(CPACK_PACKAGE_CONTACT "kcrig <kcrig@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
  "Real-time HIL controller and offline tools for a K&C suspension rig")
set(CPACK_PACKAGE_DESCRIPTION
  "A 1 kHz hardware-in-the-loop loop with safety over SocketCAN or Modbus, \
bushing-stiffness estimation, optimal experimental design and diagnosis of \
the gap between model and rig.")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# The report inlines plotly.js from the path it was built with.
set(CPACK_DEBIAN_PACKAGE_DEPENDS python3-plotly)
set(CPACK_STRIP_FILES ON)
# mpirun spreads `kcrig validate` and a campaign's batches over ranks.
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS openmpi-bin)
include(CPack)
