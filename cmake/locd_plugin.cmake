# locd_add_plugin(NAME SOURCES ...): one localizer plugin = one shared object, liblocd_<NAME>.so,
# linked against the SDK. In the locd tree it lands in build/plugins/ and installs to
# lib/locd/plugins; out of tree (after find_package(locd)) it builds the same way.
function(locd_add_plugin name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBRARIES" ${ARGN})
  add_library(locd_${name} MODULE ${ARG_SOURCES})
  if(TARGET locd_sdk)
    target_link_libraries(locd_${name} PRIVATE locd_sdk ${ARG_LIBRARIES})
  else()
    target_link_libraries(locd_${name} PRIVATE locd::locd_sdk ${ARG_LIBRARIES})
  endif()
  set_target_properties(locd_${name} PROPERTIES CXX_VISIBILITY_PRESET hidden PREFIX "lib")
  if(DEFINED LOCD_PLUGIN_OUTPUT_DIRECTORY)
    set_target_properties(locd_${name} PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${LOCD_PLUGIN_OUTPUT_DIRECTORY})
  endif()
  if(DEFINED LOCD_INSTALL_PLUGINDIR)
    install(TARGETS locd_${name} LIBRARY DESTINATION ${LOCD_INSTALL_PLUGINDIR})
  endif()
endfunction()
