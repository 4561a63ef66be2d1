# The dependency rules of the floors (docs/architecture.md): dependencies run one way, from the
# apps down to the base, and the coordinator, the codecs and the serial transport stay off the
# floors they must not reach. A rule is checked on the transitive link graph: every target's
# LINK_LIBRARIES and INTERFACE_LINK_LIBRARIES, generator expressions BUILD_INTERFACE / LINK_ONLY
# unwrapped, ALIAS targets (motion::x) resolved to their real names (motion_x), imported
# (third-party) targets left out.
#
# Two ways in:
#   include(MotionLayers)   at the end of the top-level CMakeLists.txt, once every target exists:
#                           writes the graph to ${CMAKE_BINARY_DIR}/motion_link_graph.cmake, checks
#                           the rules (a broken one stops configuration with FATAL_ERROR, naming
#                           the target and the link path to what it must not link) and registers
#                           the ctest entries below.
#   cmake -DMOTION_LINK_GRAPH=<graph file> [-DMOTION_LAYERS_ADD_EDGE=<from>:<to>] -P MotionLayers.cmake
#                           the same rules on a written graph (ctest `dependency_rules`), optionally
#                           with one more link added (ctest `dependency_rules_catch_forbidden_link`:
#                           the coordinator linking uc57_driver must be refused).

if(CMAKE_SCRIPT_MODE_FILE)
  cmake_minimum_required(VERSION 3.25)  # the project's policies (IN_LIST, ...) in script mode too
endif()

# --- The rules ---------------------------------------------------------------------------------
# motion_layers_rule(<id> "<what>" TARGETS <t>... | UNDER <dir>... [EXCEPT <t>...]
#                    FORBID <regex>... FORBID_UNDER <dir>... [THROUGH_ONLY <t>...])
#   TARGETS / UNDER     the targets the rule is about: named, or every target defined under a
#                       source folder (relative to the project root)
#   FORBID              regexes of target names they must not reach
#   FORBID_UNDER        source folders whose targets they must not reach
#   THROUGH_ONLY        targets the walk does not go through: what they link is their own business
#                       (the gateway runtime, the one owner of the simulated-bus transport)
macro(motion_layers_rules)
  set(transports "^motion_can$" "^motion_serial$" "^motion_uimessage$" "^motion_simbus$")
  # The coordinator knows the drives only through LCM and their drive models (DRIVE_MODEL): no
  # target under gateway/ (codecs included), no simulated bus, no simulator.
  motion_layers_rule(a "the coordinator (and its planner) links nothing under gateway/, no transport, simulated bus or simulator"
    TARGETS motion-coordinator motion_coordinator motion_planner
    FORBID "^motion_gateway_runtime$" "^motion_.*_driver$" ${transports}
    FORBID_UNDER gateway services/simbus services/sim)
  motion_layers_rule(b1 "no gateway target links the simulator"
    UNDER gateway
    FORBID_UNDER services/sim)
  motion_layers_rule(b2 "only the gateway runtime links the simulated bus (simbus), no stack, driver or codec does"
    UNDER gateway EXCEPT motion_gateway_runtime
    FORBID "^motion_simbus$"
    THROUGH_ONLY motion_gateway_runtime)
  motion_layers_rule(c "codecs and the frame base link no transport, configuration, LCM or runtime"
    TARGETS motion_can_frame motion_canopen motion_uim342 motion_cia402 motion_adam motion_uim242
    FORBID ${transports} "^motion_config$" "^motion_lcm$" "^motion_lcmtypes$" "^motion_app$"
           "^motion_gateway_runtime$" "^motion_.*_driver$"
    FORBID_UNDER services/sim)
  motion_layers_rule(d "the serial transport links no configuration"
    TARGETS motion_serial
    FORBID "^motion_config$")
  # The web view's libraries only watch; the program (motion-web) sends the page's commands as a
  # client of the coordinator (--controls), never past it.
  motion_layers_rule(e "the web view's libraries link no client, coordinator, gateway runtime, stack/driver, transport or simulator"
    UNDER services/web EXCEPT motion-web
    FORBID "^motion_client$" "^motion_coordinator$" "^motion_gateway_runtime$" "^motion_.*_driver$" ${transports}
    FORBID_UNDER services/sim)
  motion_layers_rule(e2 "motion-web commands only through the coordinator: no coordinator, gateway runtime, stack/driver, transport or simulator"
    TARGETS motion-web
    FORBID "^motion_coordinator$" "^motion_gateway_runtime$" "^motion_.*_driver$" ${transports}
    FORBID_UNDER services/sim)
  motion_layers_rule(f "the security library (keys, signatures) links no configuration, process skeleton, runtime, stack or transport"
    TARGETS motion_security
    FORBID "^motion_config$" "^motion_app$" "^motion_gateway_runtime$" "^motion_.*_driver$" ${transports}
    FORBID_UNDER services/sim coordinator gateway)
endmacro()

# --- The check ---------------------------------------------------------------------------------
# The graph: MOTION_LAYERS_TARGETS, and per target MOTION_LAYERS_DEPS_<t> (direct links, real
# names) and MOTION_LAYERS_DIR_<t> (source folder relative to the project root).

function(_motion_layers_forbidden target out)
  set(hit FALSE)
  foreach(regex IN LISTS ARG_FORBID)
    if(target MATCHES "${regex}")
      set(hit TRUE)
    endif()
  endforeach()
  foreach(dir IN LISTS ARG_FORBID_UNDER)
    if("${MOTION_LAYERS_DIR_${target}}/" MATCHES "^${dir}/")
      set(hit TRUE)
    endif()
  endforeach()
  set(${out} ${hit} PARENT_SCOPE)
endfunction()

# Breadth-first from `root`: the shortest link path to each forbidden target it reaches.
function(_motion_layers_walk root out)
  set(found "")
  set(visited ${root})
  set(queue ${root})
  set(path_${root} ${root})
  while(queue)
    list(POP_FRONT queue node)
    foreach(dep IN LISTS MOTION_LAYERS_DEPS_${node})
      if(dep IN_LIST visited)
        continue()
      endif()
      list(APPEND visited ${dep})
      set(path_${dep} "${path_${node}} -> ${dep}")
      _motion_layers_forbidden(${dep} forbidden)
      if(forbidden)
        list(APPEND found "${path_${dep}}")
      endif()
      if(NOT dep IN_LIST ARG_THROUGH_ONLY)
        list(APPEND queue ${dep})
      endif()
    endforeach()
  endwhile()
  set(${out} "${found}" PARENT_SCOPE)
endfunction()

function(motion_layers_rule id what)
  cmake_parse_arguments(ARG "" "" "TARGETS;UNDER;EXCEPT;FORBID;FORBID_UNDER;THROUGH_ONLY" ${ARGN})
  set(broken "")
  set(roots ${ARG_TARGETS})
  foreach(name IN LISTS ARG_TARGETS)
    if(NOT name IN_LIST MOTION_LAYERS_TARGETS)
      list(APPEND broken "rule names ${name}, which is no target (renamed? update cmake/MotionLayers.cmake)")
      list(REMOVE_ITEM roots ${name})
    endif()
  endforeach()
  foreach(dir IN LISTS ARG_UNDER)
    foreach(target IN LISTS MOTION_LAYERS_TARGETS)
      if("${MOTION_LAYERS_DIR_${target}}/" MATCHES "^${dir}/" AND NOT target IN_LIST ARG_EXCEPT)
        list(APPEND roots ${target})
      endif()
    endforeach()
  endforeach()
  foreach(root IN LISTS roots)
    _motion_layers_walk(${root} paths)
    list(APPEND broken ${paths})
  endforeach()
  list(LENGTH roots count)
  math(EXPR checked "${MOTION_LAYERS_CHECKED} + ${count}")
  set(MOTION_LAYERS_CHECKED ${checked} PARENT_SCOPE)
  if(broken)
    set(text "  (${id}) ${what}:")
    foreach(line IN LISTS broken)
      string(APPEND text "\n        ${line}")
    endforeach()
    list(APPEND MOTION_LAYERS_BROKEN "${text}")
    set(MOTION_LAYERS_BROKEN "${MOTION_LAYERS_BROKEN}" PARENT_SCOPE)
  endif()
endfunction()

# Checks the rules on the graph in scope; FATAL_ERROR listing every broken one.
macro(motion_layers_check)
  set(MOTION_LAYERS_BROKEN "")
  set(MOTION_LAYERS_CHECKED 0)
  motion_layers_rules()
  if(MOTION_LAYERS_BROKEN)
    string(JOIN "\n" _motion_layers_text ${MOTION_LAYERS_BROKEN})
    message(FATAL_ERROR "Dependency rules broken (cmake/MotionLayers.cmake, docs/architecture.md); "
                        "each line is a link path to something the target must not link:\n${_motion_layers_text}\n")
  endif()
endmacro()

# --- Script mode -------------------------------------------------------------------------------
if(CMAKE_SCRIPT_MODE_FILE)
  if(NOT MOTION_LINK_GRAPH OR NOT EXISTS "${MOTION_LINK_GRAPH}")
    message(FATAL_ERROR "MotionLayers.cmake: -DMOTION_LINK_GRAPH=<file written at configure time> is required")
  endif()
  include("${MOTION_LINK_GRAPH}")
  if(MOTION_LAYERS_ADD_EDGE)
    string(REPLACE ":" ";" _edge "${MOTION_LAYERS_ADD_EDGE}")
    list(GET _edge 0 _from)
    list(GET _edge 1 _to)
    list(APPEND MOTION_LAYERS_DEPS_${_from} ${_to})
    message(STATUS "added link ${_from} -> ${_to}")
  endif()
  motion_layers_check()
  list(LENGTH MOTION_LAYERS_TARGETS _count)
  message(STATUS "dependency rules hold: ${_count} targets in the graph, ${MOTION_LAYERS_CHECKED} checked")
  return()
endif()

# --- Configure mode: the graph from the targets ------------------------------------------------
function(_motion_layers_collect dir out)
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(sub IN LISTS subdirs)
    _motion_layers_collect(${sub} more)
    list(APPEND targets ${more})
  endforeach()
  set(${out} ${targets} PARENT_SCOPE)
endfunction()

# Direct links of `target` as real target names (aliases resolved; imported targets, plain
# library names and link flags left out).
function(_motion_layers_direct_links target out)
  get_target_property(type ${target} TYPE)
  set(items "")
  if(NOT type STREQUAL "INTERFACE_LIBRARY")
    get_target_property(items ${target} LINK_LIBRARIES)
  endif()
  get_target_property(interface_items ${target} INTERFACE_LINK_LIBRARIES)
  set(links "")
  foreach(item IN LISTS items interface_items)
    # $<BUILD_INTERFACE:x>, $<LINK_ONLY:x>, nested: unwrap; other generator expressions: skip.
    while(item MATCHES "^\\$<(BUILD_INTERFACE|LINK_ONLY):(.*)>$")
      set(item "${CMAKE_MATCH_2}")
    endwhile()
    string(REGEX REPLACE "::@\\(.*\\)$" "" item "${item}")  # directory tag of a cross-directory link
    if(item MATCHES "^\\$<" OR item MATCHES "^::@" OR NOT TARGET "${item}")
      continue()
    endif()
    get_target_property(aliased "${item}" ALIASED_TARGET)
    if(aliased)
      set(item ${aliased})
    endif()
    get_target_property(imported "${item}" IMPORTED)
    if(NOT imported AND NOT item IN_LIST links)
      list(APPEND links ${item})
    endif()
  endforeach()
  set(${out} ${links} PARENT_SCOPE)
endfunction()

_motion_layers_collect(${PROJECT_SOURCE_DIR} MOTION_LAYERS_TARGETS)
set(_motion_layers_graph "# Written by cmake/MotionLayers.cmake at configure time: the project's link graph.\n")
string(APPEND _motion_layers_graph "set(MOTION_LAYERS_TARGETS \"${MOTION_LAYERS_TARGETS}\")\n")
foreach(_target IN LISTS MOTION_LAYERS_TARGETS)
  _motion_layers_direct_links(${_target} MOTION_LAYERS_DEPS_${_target})
  get_target_property(_dir ${_target} SOURCE_DIR)
  file(RELATIVE_PATH MOTION_LAYERS_DIR_${_target} ${PROJECT_SOURCE_DIR} ${_dir})
  string(APPEND _motion_layers_graph "set(MOTION_LAYERS_DEPS_${_target} \"${MOTION_LAYERS_DEPS_${_target}}\")\n"
                                     "set(MOTION_LAYERS_DIR_${_target} \"${MOTION_LAYERS_DIR_${_target}}\")\n")
endforeach()
set(MOTION_LINK_GRAPH_FILE ${CMAKE_BINARY_DIR}/motion_link_graph.cmake)
file(WRITE ${MOTION_LINK_GRAPH_FILE} "${_motion_layers_graph}")

motion_layers_check()
list(LENGTH MOTION_LAYERS_TARGETS _count)
message(STATUS "Dependency rules hold (cmake/MotionLayers.cmake): ${_count} targets, ${MOTION_LAYERS_CHECKED} checked")

if(MOTION_BUILD_TESTS)
  add_test(NAME dependency_rules
    COMMAND ${CMAKE_COMMAND} -DMOTION_LINK_GRAPH=${MOTION_LINK_GRAPH_FILE} -P ${CMAKE_CURRENT_LIST_FILE})
  set_tests_properties(dependency_rules PROPERTIES LABELS unit TIMEOUT 60)
  # The check refuses a forbidden link: the coordinator linking a gateway stack.
  add_test(NAME dependency_rules_catch_forbidden_link
    COMMAND ${CMAKE_COMMAND} -DMOTION_LINK_GRAPH=${MOTION_LINK_GRAPH_FILE}
            -DMOTION_LAYERS_ADD_EDGE=motion_coordinator:motion_uc57_driver -P ${CMAKE_CURRENT_LIST_FILE})
  set_tests_properties(dependency_rules_catch_forbidden_link PROPERTIES LABELS unit TIMEOUT 60
    PASS_REGULAR_EXPRESSION "motion-coordinator -> motion_coordinator -> motion_uc57_driver")
  # ... and a codec: the coordinator's quantizers come from the drive model, not the family code.
  add_test(NAME dependency_rules_catch_coordinator_codec_link
    COMMAND ${CMAKE_COMMAND} -DMOTION_LINK_GRAPH=${MOTION_LINK_GRAPH_FILE}
            -DMOTION_LAYERS_ADD_EDGE=motion_planner:motion_cia402 -P ${CMAKE_CURRENT_LIST_FILE})
  set_tests_properties(dependency_rules_catch_coordinator_codec_link PROPERTIES LABELS unit TIMEOUT 60
    PASS_REGULAR_EXPRESSION "motion_planner -> motion_cia402")
  # ... and a gateway target linking the simulator.
  add_test(NAME dependency_rules_catch_gateway_simulator_link
    COMMAND ${CMAKE_COMMAND} -DMOTION_LINK_GRAPH=${MOTION_LINK_GRAPH_FILE}
            -DMOTION_LAYERS_ADD_EDGE=motion_drive_model:motion_sim_host -P ${CMAKE_CURRENT_LIST_FILE})
  set_tests_properties(dependency_rules_catch_gateway_simulator_link PROPERTIES LABELS unit TIMEOUT 60
    PASS_REGULAR_EXPRESSION "motion_drive_model -> motion_sim_host")
endif()
