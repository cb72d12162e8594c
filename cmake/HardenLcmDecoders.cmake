# Bounds every length field in the C++ decoders that lcm-gen 1.3.1 writes, before it is used.
#
# lcm-gen's _decodeNoHash() resizes a vector to a length field read from the packet before it
# checks that the packet holds that many elements, and it passes `string_len - 1` to
# std::string::assign without checking the length is positive. One changed byte in a packet
# (a negative or huge length) then throws std::length_error or std::bad_alloc out of decode(),
# i.e. out of an LCM handler, or allocates gigabytes. This script inserts, before each
#   this->FIELD.resize(this->N);      if(this->N < 0 || this->N > maxlen - pos) return -1;
#   this->FIELD[a0].resize(this->N);  (the same, for the rows of two-dimensional arrays)
# and turns each `if(__S_len__ > maxlen - pos) return -1;` into
#   if(__S_len__ < 1 || __S_len__ > maxlen - pos) return -1;
# Every element of an array takes at least one byte on the wire, so a valid message never fails
# these checks, and a vector never gets more elements than the packet has bytes left. The outer
# dimension of a two-dimensional array (rows that may be empty) is bounded by the whole message
# (maxlen) instead: its length also sizes a one-dimensional array of non-empty elements in every
# pplvo type. The build fails if lcm-gen's output does not have the expected shape.
#
# Usage: cmake -DDIR=<directory of the generated .hpp files> -P HardenLcmDecoders.cmake
cmake_minimum_required(VERSION 3.16)
if(NOT DIR)
  message(FATAL_ERROR "HardenLcmDecoders.cmake: pass -DDIR=<generated headers>")
endif()
file(GLOB headers ${DIR}/*.hpp)
if(NOT headers)
  message(FATAL_ERROR "HardenLcmDecoders.cmake: no headers in ${DIR}")
endif()
set(marker "// pplvo: length fields bounded by cmake/HardenLcmDecoders.cmake")
foreach(header ${headers})
  file(READ ${header} text)
  string(FIND "${text}" "${marker}" already)
  if(NOT already EQUAL -1)
    continue()
  endif()
  string(REGEX MATCHALL "\\.resize\\(" resizes "${text}")
  string(REGEX MATCHALL "_len__ > maxlen - pos\\) return" strings "${text}")
  list(LENGTH resizes n_resizes)
  list(LENGTH strings n_strings)

  string(REGEX REPLACE
    "\n([ ]*)this->([A-Za-z0-9_]+(\\[a0\\])?)\\.resize\\(this->([A-Za-z0-9_]+)\\);"
    "\n\\1if(this->\\4 < 0 || this->\\4 > maxlen - pos) return -1;\n\\1this->\\2.resize(this->\\4);"
    text "${text}")
  string(REGEX MATCHALL "this->[A-Za-z0-9_]+\\[a0\\]\\.resize" rows "${text}")
  foreach(row ${rows})
    string(REGEX REPLACE "this->([A-Za-z0-9_]+)\\[a0\\]\\.resize" "\\1" field "${row}")
    string(REGEX REPLACE
      "this->([A-Za-z0-9_]+) > maxlen - pos\\) return -1;(\n[ ]*this->${field}\\.resize)"
      "this->\\1 > maxlen) return -1;\\2" text "${text}")
  endforeach()
  string(REGEX REPLACE "if\\(__([A-Za-z0-9_]+)_len__ > maxlen - pos\\) return -1;"
    "if(__\\1_len__ < 1 || __\\1_len__ > maxlen - pos) return -1;" text "${text}")

  string(REGEX MATCHALL " < 0 \\|\\| this->" guarded "${text}")
  string(REGEX MATCHALL "_len__ < 1 \\|\\| __" guarded_strings "${text}")
  list(LENGTH guarded n_guarded)
  list(LENGTH guarded_strings n_guarded_strings)
  if(NOT n_guarded EQUAL n_resizes OR NOT n_guarded_strings EQUAL n_strings)
    message(FATAL_ERROR "HardenLcmDecoders.cmake: ${header}: bounded ${n_guarded} of "
      "${n_resizes} resizes and ${n_guarded_strings} of ${n_strings} strings: lcm-gen's output "
      "changed shape; update the patterns")
  endif()
  file(WRITE ${header} "${marker}\n${text}")
endforeach()
