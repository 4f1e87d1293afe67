# Writes the version stamp (build_info.f90) at every build, not only at configure time, so a
# result file names the commit its program was built from. configure_file rewrites the file only
# when the stamp changed: an unchanged tree recompiles nothing.
# Inputs: SOURCE_DIR, TEMPLATE, OUTPUT, PROJECT_VERSION, GIT_EXECUTABLE (may be empty).
set(BEADMOB_GIT_HASH "unknown")
if(GIT_EXECUTABLE AND EXISTS "${SOURCE_DIR}/.git")
  execute_process(COMMAND ${GIT_EXECUTABLE} describe --always --dirty --abbrev=12
                  WORKING_DIRECTORY ${SOURCE_DIR}
                  OUTPUT_VARIABLE BEADMOB_GIT_HASH OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
endif()
configure_file(${TEMPLATE} ${OUTPUT} @ONLY)
