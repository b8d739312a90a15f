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
message(STATUS "deal.II ${DEAL_II_PACKAGE_VERSION} at ${DEAL_II_PATH}; gmsh ${GMSH_LIBRARY}; CHOLMOD ${CHOLMOD_LIBRARY}")
