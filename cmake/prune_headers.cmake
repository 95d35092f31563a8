# Run by `cmake --install` after pgi's headers (CMakeLists.txt): removes the headers an earlier install of pgi put
# in the prefix that this one no longer installs (a header moved to detail/, or removed), then lists this install's
# headers for the next. Only files named in pgi's own list (written by a previous install) are removed, and only
# regular files under include/pgi named by a relative path: a file pgi did not install is never touched. Nothing is
# removed unless every header of this install is found where the list's names point (a prefix or a directory this
# script would resolve otherwise than the install did). An install made before pgi kept the list leaves its old
# headers (remove <prefix>/include/pgi by hand once).
# Reads PGI_HEADERS (this install's headers, relative to include/pgi), PGI_INCLUDE_DIR and PGI_HEADER_LIST (relative
# to the prefix, or absolute), set by the install code before it.
function(installed_path out path)
  if(NOT IS_ABSOLUTE "${path}")
    set(path "${CMAKE_INSTALL_PREFIX}/${path}")
  endif()
  get_filename_component(path "${path}" ABSOLUTE)
  set(${out} "$ENV{DESTDIR}${path}" PARENT_SCOPE)
endfunction()
installed_path(headers "${PGI_INCLUDE_DIR}/pgi")
installed_path(list_file "${PGI_HEADER_LIST}")
set(now ${PGI_HEADERS})
set(found TRUE)
foreach(relative ${now})
  if(NOT EXISTS "${headers}/${relative}")
    set(found FALSE)
  endif()
endforeach()
if(NOT now OR NOT found)
  message(WARNING "pgi: this install's headers are not all under ${headers}: no old header removed, no list kept")
  return()
endif()
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
string(LENGTH "$ENV{DESTDIR}" skip)
string(SUBSTRING "${list_file}" ${skip} -1 listed)
list(APPEND CMAKE_INSTALL_MANIFEST_FILES "${listed}")
message(STATUS "Installing: ${list_file}")
