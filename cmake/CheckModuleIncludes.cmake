# Configure-time check of the module layout (docs/ARCHITECTURE.md): a file of
# module M (src/M/*, include/mcvo/M/*) may include "mcvo/N/..." only when
# mcvo_N is M itself or one of M's link dependencies (direct or transitive),
# and tools/ only modules the mcvo executable links. A header from a module
# that is not linked compiles today and breaks the day it gains a .cc file;
# this stops the configure step with the file and the include instead.
#
#   mcvo_check_module_includes(MODULES util geometry ...)

# Every mcvo_* target `target` links, directly or through another, into out.
function(_mcvo_linked_modules target out)
  set(seen "")
  set(queue ${target})
  while(queue)
    list(POP_FRONT queue current)
    foreach(property LINK_LIBRARIES INTERFACE_LINK_LIBRARIES)
      get_target_property(libs ${current} ${property})
      if(NOT libs)
        continue()
      endif()
      foreach(lib ${libs})
        if(lib MATCHES "^mcvo_([a-z_]+)$" AND TARGET ${lib} AND NOT lib IN_LIST seen)
          list(APPEND seen ${lib})
          list(APPEND queue ${lib})
        endif()
      endforeach()
    endforeach()
  endwhile()
  set(modules "")
  foreach(lib ${seen})
    string(REGEX REPLACE "^mcvo_" "" module ${lib})
    list(APPEND modules ${module})
  endforeach()
  set(${out} ${modules} PARENT_SCOPE)
endfunction()

# Appends "file: #include ..." to the list variable named by `list_name` for
# each include in `files` of a module not in `allowed`.
function(_mcvo_check_files files allowed list_name)
  set(found ${${list_name}})
  foreach(file ${files})
    file(STRINGS ${file} includes REGEX "^#include \"mcvo/[a-z_]+/")
    foreach(line ${includes})
      string(REGEX REPLACE "^#include \"mcvo/([a-z_]+)/.*$" "\\1" module "${line}")
      if(NOT module IN_LIST allowed)
        file(RELATIVE_PATH relative ${PROJECT_SOURCE_DIR} ${file})
        list(APPEND found "${relative}: ${line} (mcvo_${module} is not a link dependency)")
      endif()
    endforeach()
  endforeach()
  set(${list_name} ${found} PARENT_SCOPE)
endfunction()

function(mcvo_check_module_includes)
  cmake_parse_arguments(ARG "" "" "MODULES" ${ARGN})
  set(violations "")
  foreach(module ${ARG_MODULES})
    _mcvo_linked_modules(mcvo_${module} allowed)
    list(APPEND allowed ${module})
    file(GLOB_RECURSE files ${PROJECT_SOURCE_DIR}/src/${module}/*.cc ${PROJECT_SOURCE_DIR}/src/${module}/*.h
         ${PROJECT_SOURCE_DIR}/include/mcvo/${module}/*.h)
    _mcvo_check_files("${files}" "${allowed}" violations)
  endforeach()
  _mcvo_linked_modules(mcvo allowed)
  file(GLOB files ${PROJECT_SOURCE_DIR}/tools/*.cc ${PROJECT_SOURCE_DIR}/tools/*.h)
  _mcvo_check_files("${files}" "${allowed}" violations)
  if(violations)
    list(JOIN violations "\n  " text)
    message(FATAL_ERROR "includes across modules that are not linked (docs/ARCHITECTURE.md):\n  ${text}")
  endif()
endfunction()
