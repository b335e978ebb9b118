# The viewer's tests, included by CMakeLists.txt; only when cvtmesh-gui is built.
#   test_render_logic, test_render_data, test_gui_logic
#                                      GL-free logic of render/ and app/gui/, no window
#   test_gui_*                         cvtmesh-gui scripted under xvfb-run (Mesa llvmpipe), its
#                                      PNGs checked by check_screenshot (libpng); inputs
#                                      sent as GLFW drop and key events (--drop, --press)
if(NOT CVTMESH_BUILD_GUI)
  return()
endif()

cvt_add_test(test_render_logic test_render_logic.cpp)
target_link_libraries(test_render_logic PRIVATE cvtrender_logic)
cvt_add_test(test_render_data test_render_data.cpp)
target_link_libraries(test_render_data PRIVATE cvtrender_logic)
cvt_add_test(test_gui_logic test_gui_logic.cpp)
target_link_libraries(test_gui_logic PRIVATE cvtgui_logic)
# The session's export is checked against the CLI's output.
target_compile_definitions(test_gui_logic PRIVATE CVTMESH_CLI="$<TARGET_FILE:cvtmesh>")
add_dependencies(test_gui_logic cvtmesh)

add_executable(check_screenshot check_screenshot.cpp)
target_link_libraries(check_screenshot PRIVATE PNG::PNG)

find_program(XVFB_RUN xvfb-run)
if(NOT XVFB_RUN)
  message(STATUS "xvfb-run not found: the cvtmesh-gui screenshot tests are skipped")
  return()
endif()
set(CVT_GUI_RUN ${CMAKE_CURRENT_SOURCE_DIR}/gui_screenshot_test.sh ${XVFB_RUN}
    $<TARGET_FILE:cvtmesh-gui> $<TARGET_FILE:check_screenshot>)
set(CVT_LIVER ${PROJECT_SOURCE_DIR}/data/liver.inr.gz)
set(CVT_GUI_OUT ${CMAKE_CURRENT_BINARY_DIR}/gui)
# Arguments: PNG, expected width and height, least non-background fraction, least distinct
# colours, then the program's arguments.

# The real liver (scripts/fetch-data): a 3D cut-away coloured by quality, and an axial slice
# with the discrete Voronoi cells at 2x the window size.
if(EXISTS ${CVT_LIVER})
  # While the jobs run, the views' picture is re-shown rather than drawn again (view_cache.h).
  add_test(NAME test_gui_liver_cutaway COMMAND ${CVT_GUI_RUN}
    --expect-output "^views: [0-9]+ frames drawn, [1-9][0-9]* re-shown"
    ${CVT_GUI_OUT}/liver_cutaway.png 1280 800 0.08 200
    ${CVT_LIVER} --run-all --view 3d --clip 0.5 --colour-by v_over_rmc3)
  add_test(NAME test_gui_liver_voronoi COMMAND ${CVT_GUI_RUN}
    ${CVT_GUI_OUT}/liver_voronoi.png 2560 1600 0.25 300
    ${CVT_LIVER} --run-all --view slice --slice-axis 2 --overlay object voronoi samples interior
    shallow --scale 2)
  # Stage 6 stepped pass by pass to the end, then evaluated: the whole window, the quality
  # panel showing Table I and histograms before and after, the cut-away by min dihedral.
  add_test(NAME test_gui_liver_optimized COMMAND ${CVT_GUI_RUN}
    --expect-output "^stage 6: [1-9][0-9]* passes"
    ${CVT_GUI_OUT}/liver_optimized.png 1280 800 0.3 300
    ${CVT_LIVER} --run-all --optimize-passes -1 --view 3d --clip 0.5
    --colour-by min_dihedral_deg --screenshot-ui)
  # Under ASan + UBSan the liver runs several times slower: the cut-away took 120 s alone and
  # over 180 s beside another liver test (scripts/test --sanitize runs two at a time).
  set(cvt_slow 1)
  if(CVTMESH_SANITIZE)
    set(cvt_slow 3)
  endif()
  math(EXPR cvt_timeout "180 * ${cvt_slow}")
  set_tests_properties(test_gui_liver_cutaway test_gui_liver_voronoi PROPERTIES
    TIMEOUT ${cvt_timeout})
  # Stage 5 twice (once without, once with stage 6) and ten snapshots of the mesh.
  math(EXPR cvt_timeout "300 * ${cvt_slow}")
  set_tests_properties(test_gui_liver_optimized PROPERTIES TIMEOUT ${cvt_timeout})
else()
  message(STATUS "${CVT_LIVER} missing (scripts/fetch-data): the liver viewer tests are skipped")
endif()
# The committed torus phantom, both views, transparent background (lfs and medial axis).
add_test(NAME test_gui_phantom_split COMMAND ${CVT_GUI_RUN}
  ${CVT_GUI_OUT}/torus_split.png 1280 800 0.15 100
  ${PROJECT_SOURCE_DIR}/assets/phantom_torus.nii.gz --run-all --view split --clip 0.5
  --overlay object lfs medial samples --transparent)
# Inputs as events: the torus dropped on the window through GLFW's drop callback, then Ctrl+R
# (run all) and Shift+O (optimise to the end) as GLFW key events; without them the 3D view
# would stay empty.
add_test(NAME test_gui_drop_and_keys COMMAND ${CVT_GUI_RUN}
  --expect-output "^stage 6: [1-9][0-9]* passes"
  ${CVT_GUI_OUT}/torus_drop_keys.png 1280 800 0.05 50
  --drop ${PROJECT_SOURCE_DIR}/assets/phantom_torus.nii.gz --press ctrl+r shift+o --view 3d
  --clip 0.5)
set_tests_properties(test_gui_drop_and_keys PROPERTIES TIMEOUT 60)
# A bad file: exit code 1 and one line on stderr, no screenshot.
add_test(NAME test_gui_bad_file COMMAND ${CVT_GUI_RUN} --expect-failure
  ${CVT_GUI_OUT}/bad.png 0 0 0 0 ${CMAKE_CURRENT_SOURCE_DIR}/CMakeLists.txt --run-all)
set_tests_properties(test_gui_phantom_split test_gui_bad_file PROPERTIES TIMEOUT 60)
