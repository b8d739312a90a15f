# Finds what the offline stages stand on and says clearly what is missing.
find_package(deal.II 9.4 QUIET HINTS ${DEAL_II_DIR} $ENV{DEAL_II_DIR})
if(NOT deal.II_FOUND)
  message(FATAL_ERROR
    "deal.II 9.4 was not found. Install it with scripts/setup (Debian: libdeal.ii-dev), "
    "point DEAL_II_DIR at it, or configure with -DMODAL_HAPTICS_WITH_DEALII=OFF to build the real-time kernel only.")
endif()
foreach(feature ARPACK HDF5 TRILINOS UMFPACK MPI)
  if(NOT DEAL_II_WITH_${feature})
    message(FATAL_ERROR "deal.II at ${DEAL_II_PATH} was built without ${feature}; modal-haptics needs it.")
  endif()
endforeach()

# Debian's deal.II carries the distribution's own build flags in DEAL_II_CXX_FLAGS, '-g' among them,
# which DEAL_II_SETUP_TARGET passes to every translation unit of ours: debug information makes each
# deal.II unit about a quarter slower to compile and ten times larger (docs/performance.md, "No debug
# information in Release"). A Debug build gets '-ggdb' from DEAL_II_CXX_FLAGS_DEBUG all the same.
option(MODAL_HAPTICS_DEBUG_INFO "Keep '-g' from deal.II's flags in the offline targets" OFF)
if(NOT MODAL_HAPTICS_DEBUG_INFO)
  separate_arguments(_deal_ii_flags UNIX_COMMAND "${DEAL_II_CXX_FLAGS}")
  list(REMOVE_ITEM _deal_ii_flags "-g")
  string(JOIN " " DEAL_II_CXX_FLAGS ${_deal_ii_flags})
endif()

find_path(GMSH_INCLUDE_DIR gmsh.h)
find_library(GMSH_LIBRARY NAMES gmsh)
if(NOT GMSH_INCLUDE_DIR OR NOT GMSH_LIBRARY)
  message(FATAL_ERROR "gmsh's C++ API was not found (gmsh.h, libgmsh). Install it with scripts/setup (Debian: libgmsh-dev).")
endif()

find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(CHOLMOD_LIBRARY NAMES cholmod)
if(NOT CHOLMOD_INCLUDE_DIR OR NOT CHOLMOD_LIBRARY)
  message(FATAL_ERROR "SuiteSparse's CHOLMOD was not found (cholmod.h, libcholmod). Install it with scripts/setup (Debian: libsuitesparse-dev).")
endif()
find_path(METIS_INCLUDE_DIR metis.h)
find_library(METIS_LIBRARY NAMES metis)
if(NOT METIS_INCLUDE_DIR OR NOT METIS_LIBRARY)
  message(FATAL_ERROR "METIS was not found (metis.h, libmetis). Install it with scripts/setup (Debian: libmetis-dev).")
endif()
# MUMPS's C interface (double precision, MPI): the distributed factorization, called directly.
find_path(MUMPS_INCLUDE_DIR dmumps_c.h)
find_library(MUMPS_LIBRARY NAMES dmumps)
if(NOT MUMPS_INCLUDE_DIR OR NOT MUMPS_LIBRARY)
  message(FATAL_ERROR "MUMPS was not found (dmumps_c.h, libdmumps). Install it with scripts/setup (Debian: libmumps-dev).")
endif()
# nlohmann/json (header-only): report.json is written with it.
find_package(nlohmann_json 3.9 QUIET)
if(NOT nlohmann_json_FOUND)
  message(FATAL_ERROR "nlohmann/json 3.9 or later (ordered_json) was not found (nlohmann_jsonConfig.cmake). Install it with scripts/setup (Debian: nlohmann-json3-dev).")
endif()
message(STATUS "deal.II ${DEAL_II_PACKAGE_VERSION} at ${DEAL_II_PATH}; gmsh ${GMSH_LIBRARY}; CHOLMOD ${CHOLMOD_LIBRARY}; METIS ${METIS_LIBRARY}; MUMPS ${MUMPS_LIBRARY}")
