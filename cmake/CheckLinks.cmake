# cmake -DLINKS=FILE -DFORBIDDEN=a,b -P CheckLinks.cmake: fails naming
# every forbidden library in FILE (written by holofuse_link_closure) and
# the library that linked it.
cmake_minimum_required(VERSION 3.20)
string(REPLACE "," ";" FORBIDDEN "${FORBIDDEN}")
file(STRINGS "${LINKS}" chains)
set(found "")
foreach(chain ${chains})
  string(REGEX REPLACE "<-.*" "" library "${chain}")
  if(library IN_LIST FORBIDDEN)
    list(APPEND found "${chain}")
  endif()
endforeach()
if(found)
  string(REPLACE ";" "\n  " lines "${found}")
  message(FATAL_ERROR "${LINKS}: links what it must not (library<-linked by):\n  ${lines}")
endif()
list(LENGTH chains count)
message(STATUS "${count} libraries linked, none of: ${FORBIDDEN}")
