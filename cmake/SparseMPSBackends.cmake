# hypre, CHOLMOD, Zoltan and PETSc ship no usable CMake package on Debian 12 (Zoltan's imports its library under the
# configuration NONE only), so they are found by library (and, for the build, by
# header) and wrapped in imported targets: a static libsparsemps's exported link interface then names
# SparseMPS::HYPRE etc. rather than this machine's paths, and the installed SparseMPSConfig.cmake of a static build
# includes this file to find them again wherever the package is used.
#
# In:  SPARSEMPS_BACKEND_HEADERS  ON in the build (headers wanted), OFF from the package config (only libraries)
#      SPARSEMPS_BACKEND_HINTS    directories to search first (the config passes where the build found them)
# Out: targets SparseMPS::HYPRE, SparseMPS::CHOLMOD, SparseMPS::suitesparseconfig, SparseMPS::Zoltan (and, in the
#      build, SparseMPS::PETSc);
#      SPARSEMPS_BACKENDS_MISSING lists what was not found (empty when all were).
set(SPARSEMPS_BACKENDS_MISSING "")

# target, cache variable of the library, library name, then (build only) header, its cache variable and suffix
function(_sparsemps_import target library_var library header header_var header_suffix)
  find_library(${library_var} NAMES ${library} HINTS ${SPARSEMPS_BACKEND_HINTS} DOC "lib${library}")
  if(NOT ${library_var})
    set(SPARSEMPS_BACKENDS_MISSING ${SPARSEMPS_BACKENDS_MISSING} lib${library} PARENT_SCOPE)
    return()
  endif()
  if(SPARSEMPS_BACKEND_HEADERS AND header)
    find_path(${header_var} ${header} PATH_SUFFIXES ${header_suffix} DOC "directory of ${header}")
    if(NOT ${header_var})
      set(SPARSEMPS_BACKENDS_MISSING ${SPARSEMPS_BACKENDS_MISSING} ${header} PARENT_SCOPE)
      return()
    endif()
  endif()
  if(NOT TARGET ${target})
    add_library(${target} UNKNOWN IMPORTED)
    set_target_properties(${target} PROPERTIES IMPORTED_LOCATION "${${library_var}}")
    if(SPARSEMPS_BACKEND_HEADERS AND header)
      # Imported include directories are SYSTEM: the backends' headers stay out of our warnings (and -Werror).
      set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${${header_var}}")
    endif()
  endif()
endfunction()

_sparsemps_import(SparseMPS::HYPRE HYPRE_LIBRARY HYPRE HYPRE.h HYPRE_INCLUDE_DIR hypre)
_sparsemps_import(SparseMPS::CHOLMOD CHOLMOD_LIBRARY cholmod cholmod.h CHOLMOD_INCLUDE_DIR suitesparse)
# CHOLMOD's own dependencies (AMD, COLAMD, METIS, LAPACK/BLAS) come in through libcholmod.so; its BLAS is the
# libblas.so.3 alternative, which Debian points at OpenBLAS once libopenblas-dev is installed.
_sparsemps_import(SparseMPS::suitesparseconfig SUITESPARSECONFIG_LIBRARY suitesparseconfig "" "" "")
# Zoltan (Debian: libtrilinos-zoltan-dev): the partitioner of mps/parallel/distributed.cpp; its headers under trilinos/.
_sparsemps_import(SparseMPS::Zoltan ZOLTAN_LIBRARY trilinos_zoltan zoltan.h ZOLTAN_INCLUDE_DIR trilinos)
# PETSc (Debian: libpetsc-real-dev): the petsc backend's module (lib/mps/solvers/petsc_ksp.cpp), built with the library;
# programs using the library never link it.
if(SPARSEMPS_BACKEND_HEADERS)
  _sparsemps_import(SparseMPS::PETSc PETSC_LIBRARY petsc_real petsc.h PETSC_INCLUDE_DIR petsc)
endif()
