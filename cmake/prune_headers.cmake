# Run by `cmake --install` after pgi's headers (CMakeLists.txt): removes the headers an earlier install of pgi put
# in the prefix that this one no longer installs (a header moved to detail/, or removed), then lists this install's
# headers for the next. Only files named in pgi's own list (PGI_HEADER_LIST, written by a previous install) are
# removed, and only regular files under include/pgi: a file pgi did not install is never touched. An install made
# before pgi kept the list leaves its old headers (remove <prefix>/include/pgi by hand once).
# Reads PGI_INCLUDE_DIR and PGI_HEADER_LIST (relative to the prefix), set by the install code before it.
# (the install's list of files names them without $DESTDIR; the files themselves are under it)
set(installed_headers "${CMAKE_INSTALL_PREFIX}/${PGI_INCLUDE_DIR}/pgi")
set(headers "$ENV{DESTDIR}${installed_headers}")
set(list_file "$ENV{DESTDIR}${CMAKE_INSTALL_PREFIX}/${PGI_HEADER_LIST}")
# this install's headers, relative to include/pgi
set(now "")
foreach(f ${CMAKE_INSTALL_MANIFEST_FILES})
  string(FIND "${f}" "${installed_headers}/" at)
  if(at EQUAL 0)
    file(RELATIVE_PATH relative "${installed_headers}" "${f}")
    list(APPEND now "${relative}")
  endif()
endforeach()
if(EXISTS "${list_file}")
  file(STRINGS "${list_file}" before)
  foreach(relative ${before})
    # a name pgi wrote: relative, no parent step, a header
    if(relative MATCHES "^/" OR relative MATCHES "(^|/)\\.\\.(/|$)" OR NOT relative MATCHES "^[A-Za-z0-9_./-]+\\.hpp$")
      continue()
    endif()
    list(FIND now "${relative}" kept)
    set(old "${headers}/${relative}")
    if(kept EQUAL -1 AND EXISTS "${old}" AND NOT IS_SYMLINK "${old}" AND NOT IS_DIRECTORY "${old}")
      message(STATUS "Removing (no longer installed): ${old}")
      file(REMOVE "${old}")
    endif()
  endforeach()
endif()
list(SORT now)
string(REPLACE ";" "\n" text "${now}")
file(WRITE "${list_file}" "${text}\n")
list(APPEND CMAKE_INSTALL_MANIFEST_FILES "${CMAKE_INSTALL_PREFIX}/${PGI_HEADER_LIST}")
message(STATUS "Installing: ${list_file}")
