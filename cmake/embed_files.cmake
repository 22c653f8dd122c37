# zoomwarp_embed(TARGET FUNCTION FILES f1 f2 ...)
#
# A static library TARGET whose generated source defines
#   std::optional<std::string_view> FUNCTION(std::string_view file_name);
# returning the bytes of each listed file by its base name (nullopt for others). The files are
# read at build time and rebuilt into the library when they change, so the binary needs nothing
# beside it at run time (the web viewer, the OpenAPI document). Declare FUNCTION in a header.
function(zoomwarp_embed target function)
  cmake_parse_arguments(ARG "" "" "FILES" ${ARGN})
  set(out ${CMAKE_CURRENT_BINARY_DIR}/${target}.cc)
  add_custom_command(
    OUTPUT ${out}
    COMMAND ${CMAKE_COMMAND} -DOUT=${out} -DFUNCTION=${function} "-DFILES=${ARG_FILES}"
            -P ${PROJECT_SOURCE_DIR}/cmake/embed_files_script.cmake
    DEPENDS ${ARG_FILES} ${PROJECT_SOURCE_DIR}/cmake/embed_files_script.cmake
    COMMENT "Embedding ${target}"
    VERBATIM)  # FILES is a ;-list: quoted for the shell, not split into commands
  add_library(${target} STATIC ${out})
endfunction()
