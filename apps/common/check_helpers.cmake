# The apps' end-to-end checks (cmake -P scripts) share these:
#   run (<command> [args...])        runs it (240 s at most), prints its output, fails on a
#                                    non-zero exit; the output is left in LAST_OUT
#   expect (<what> <regex>)          fails unless LAST_OUT matches
#   require_file (<path> [<bytes>])  fails unless the file exists with at least <bytes> (1000)
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 240)
  message(STATUS "${out}${err}")
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}")
  endif()
  set(LAST_OUT "${out}" PARENT_SCOPE)
endfunction()

function(expect what regex)
  if(NOT LAST_OUT MATCHES "${regex}")
    message(FATAL_ERROR "${what}: no match for '${regex}'")
  endif()
endfunction()

function(require_file f)
  set(min 1000)
  if(ARGC GREATER 1)
    set(min ${ARGV1})
  endif()
  if(NOT EXISTS ${f})
    message(FATAL_ERROR "missing ${f}")
  endif()
  file(SIZE ${f} size)
  if(size LESS min)
    message(FATAL_ERROR "${f} is too small (${size} bytes, want >= ${min})")
  endif()
endfunction()
