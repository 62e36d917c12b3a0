# The fuzz targets (tests/fuzz/README.md) and the library each links. Included by
# tests/fuzz/CMakeLists.txt (the clang sub-build) and tests/CMakeLists.txt (the corpus regression
# tests of the ordinary build).
set(STICKSLIP_FUZZ_TARGETS study_spec measured diagnosis_request http page_token)
set(STICKSLIP_FUZZ_LIBS_study_spec stickslip_studies)
set(STICKSLIP_FUZZ_LIBS_measured stickslip_measured)
set(STICKSLIP_FUZZ_LIBS_diagnosis_request stickslip_diagnosis)
set(STICKSLIP_FUZZ_LIBS_http stickslip_server)
set(STICKSLIP_FUZZ_LIBS_page_token stickslip_server)
