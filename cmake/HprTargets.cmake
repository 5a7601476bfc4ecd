# Helpers shared by every target of the tree: warnings, optimisation, install export.

function(hpr_set_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
    -Woverloaded-virtual -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough
    -Wmisleading-indentation)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(${target} PRIVATE -Wduplicated-cond -Wlogical-op)
  endif()
  if(HPR_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

function(hpr_set_options target)
  hpr_set_warnings(${target})
  if(HPR_NATIVE)
    target_compile_options(${target} PRIVATE -march=native)
  endif()
  if(HPR_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
    if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
      # GCC 12's dynamic-type check (-fsanitize=vptr) of the pointer-to-member call in LCM's
      # member-function subscription (lcm-cpp-impl.hpp, LCMMHUntypedSubscription::cb_func) calls the
      # handler on a wrong object: every node would crash on its first message. Clang checks it fine.
      target_compile_options(${target} PRIVATE -fno-sanitize=vptr)
      # The instrumentation makes GCC's flow analysis report std::function members inside
      # <regex> as maybe uninitialized (false positives the plain build does not show).
      target_compile_options(${target} PRIVATE -Wno-maybe-uninitialized)
    endif()
  endif()
  if(HPR_SANITIZE_THREAD)
    target_compile_options(${target} PRIVATE -fsanitize=thread -fno-omit-frame-pointer)
    target_link_options(${target} PRIVATE -fsanitize=thread)
  endif()
  if(HPR_UNITY_BUILD)
    # One translation unit per batch of up to 8 sources: the headers every source includes (Eigen,
    # the standard library, yaml-cpp, the generated LCM types) are parsed and instantiated once per
    # batch. Names local to a source (anonymous namespaces) must therefore differ within a target;
    # the builds without it (the asan, tsan and debug presets) check that each source compiles alone.
    set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 8)
  endif()
  if(HPR_BUILD_FUZZERS)
    # Coverage feedback for libFuzzer from every library the targets call.
    target_compile_options(${target} PRIVATE -fsanitize=fuzzer-no-link)
  endif()
endfunction()

# hpr_add_library(NAME <name> SOURCES ... DEPS ... [PRIVATE_DEPS ...])
#   Builds hpr_<name> with alias hpr::<name>, public headers under ./include, installed and exported.
function(hpr_add_library)
  cmake_parse_arguments(A "" "NAME;DIR" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  if(NOT A_DIR)
    set(A_DIR ${CMAKE_CURRENT_SOURCE_DIR})
  endif()
  set(t hpr_${A_NAME})
  add_library(${t} ${A_SOURCES})
  add_library(hpr::${A_NAME} ALIAS ${t})
  set_target_properties(${t} PROPERTIES EXPORT_NAME ${A_NAME} OUTPUT_NAME hpr_${A_NAME})
  target_include_directories(${t} PUBLIC
    $<BUILD_INTERFACE:${A_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${t} PUBLIC ${A_DEPS} PRIVATE ${A_PRIVATE_DEPS})
  target_compile_features(${t} PUBLIC cxx_std_20)
  hpr_set_options(${t})
  install(TARGETS ${t} EXPORT hprTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(DIRECTORY ${A_DIR}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endfunction()

# hpr_add_executable(NAME <name> SOURCES ... DEPS ...)
#   A program of the stack (a process, a tool, a benchmark), installed and part of target hpr_stack.
function(hpr_add_executable)
  cmake_parse_arguments(A "" "NAME" "SOURCES;DEPS" ${ARGN})
  add_executable(${A_NAME} ${A_SOURCES})
  set_property(GLOBAL APPEND PROPERTY HPR_STACK_TARGETS ${A_NAME})
  target_link_libraries(${A_NAME} PRIVATE ${A_DEPS})
  hpr_set_options(${A_NAME})
  set_target_properties(${A_NAME} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bin)
  install(TARGETS ${A_NAME} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endfunction()
