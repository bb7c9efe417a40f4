# Checks shared by the benches' CTest smoke scripts (cmake -P).

# expect_method_rows(<output> <prefix> <tail> <what> <method>...): fails unless <output> holds,
# for every method, a row matching "<prefix>,<method>,<tail>"; <what> names such a row.
function(expect_method_rows output prefix tail what)
  foreach(m ${ARGN})
    if(NOT output MATCHES "${prefix},${m},${tail}")
      message(FATAL_ERROR "no ${what} row for ${m}\n${output}")
    endif()
  endforeach()
endfunction()
