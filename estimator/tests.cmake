# Unit tests of the library stages. One executable per stage source.
function(weavefit_unit_test name source)
  add_executable(${name} ${source})
  target_link_libraries(${name} PRIVATE weavefit_estimator GTest::gtest_main
    opencv_core opencv_imgcodecs)
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES LABELS unit)
endfunction()
include(GoogleTest)
weavefit_unit_test(decode_test io/decode_test.cc)
weavefit_unit_test(azimuth_mapping_test cylinder/azimuth_mapping_test.cc)
weavefit_unit_test(radiance_test optics/radiance_test.cc)
weavefit_unit_test(cylinder_detection_test cylinder/cylinder_detection_test.cc)
