# All dependencies are Debian packages (scripts/install-deps.sh installs them).
# Each becomes an imported target; modules link only what their .cpp files use.

find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(TBB REQUIRED)
find_package(Threads REQUIRED)

# CGAL (header-only in 5.x); its own CMake config insists on a build type.
set(CGAL_DO_NOT_WARN_ABOUT_CMAKE_BUILD_TYPE TRUE)
find_package(CGAL REQUIRED)

# SuiteSparse / CHOLMOD for Eigen's CholmodSupport.
find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse REQUIRED)
foreach(lib cholmod amd colamd camd ccolamd suitesparseconfig)
  find_library(T2S_${lib}_LIBRARY ${lib} REQUIRED)
  list(APPEND CHOLMOD_LIBRARIES ${T2S_${lib}_LIBRARY})
endforeach()
add_library(t2s_cholmod INTERFACE)
target_include_directories(t2s_cholmod SYSTEM INTERFACE ${CHOLMOD_INCLUDE_DIR})
target_link_libraries(t2s_cholmod INTERFACE ${CHOLMOD_LIBRARIES})

# TetGen 1.5 (libtet1.5-dev): used as a library, it throws instead of exiting.
find_path(TETGEN_INCLUDE_DIR tetgen.h REQUIRED)
find_library(TETGEN_LIBRARY tet REQUIRED)
add_library(t2s_tetgen INTERFACE)
target_include_directories(t2s_tetgen SYSTEM INTERFACE ${TETGEN_INCLUDE_DIR})
target_compile_definitions(t2s_tetgen INTERFACE TETLIBRARY)
target_link_libraries(t2s_tetgen INTERFACE ${TETGEN_LIBRARY})

# OpenCASCADE 7.6 (libocct-*-dev). Debian's OpenCASCADEConfig.cmake insists on
# every OCCT module (visualisation, OCAF) being installed, so find the
# toolkits we use directly.
find_path(OCCT_INCLUDE_DIR Standard.hxx PATH_SUFFIXES opencascade REQUIRED)
add_library(t2s_occt INTERFACE)
target_include_directories(t2s_occt SYSTEM INTERFACE ${OCCT_INCLUDE_DIR})
foreach(tk TKSTEP TKSTEPBase TKSTEPAttr TKSTEP209 TKIGES TKXSBase TKMesh TKBO TKBool
           TKFillet TKOffset TKPrim TKShHealing TKTopAlgo TKGeomAlgo TKBRep TKGeomBase
           TKG3d TKG2d TKMath TKernel)
  find_library(T2S_OCCT_${tk} ${tk} REQUIRED)
  target_link_libraries(t2s_occt INTERFACE ${T2S_OCCT_${tk}})
endforeach()

find_package(Ceres REQUIRED)
find_package(CLI11 REQUIRED)
find_package(nlohmann_json 3.9 REQUIRED)
