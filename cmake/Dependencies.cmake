# Every dependency is a Debian bookworm package installed by scripts/setup (docs/design.md §7).
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(assimp REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(CLI11 REQUIRED)
find_package(spdlog REQUIRED)
find_package(fmt REQUIRED)
find_package(TBB REQUIRED)
find_package(Threads REQUIRED)
# Boost.Math (header only): the F distribution of the reports' one-way ANOVA (training module);
# Boost.Beast (header only): HTTP and WebSocket of the Haply backend (device module).
find_package(Boost 1.74 REQUIRED)
# nlohmann-json (header only): the Haply Inverse Service's JSON messages (device module).
find_package(nlohmann_json 3 REQUIRED)
find_package(PkgConfig REQUIRED)
pkg_check_modules(SQLITE3 REQUIRED IMPORTED_TARGET sqlite3)
# OpenSSL's libcrypto: PBKDF2-HMAC-SHA256 for the course file's instructor passphrase (training module).
find_package(OpenSSL REQUIRED COMPONENTS Crypto)

# OpenVDB 10 on bookworm: link directly (its CMake module needs Blosc/Boost components we do not use).
find_path(OPENVDB_INCLUDE_DIR openvdb/openvdb.h REQUIRED)
find_library(OPENVDB_LIBRARY openvdb REQUIRED)
find_library(IMATH_LIBRARY Imath-3_1 REQUIRED)
add_library(cariesim_openvdb INTERFACE)
target_include_directories(cariesim_openvdb SYSTEM INTERFACE ${OPENVDB_INCLUDE_DIR})
target_link_libraries(cariesim_openvdb INTERFACE ${OPENVDB_LIBRARY} TBB::tbb ${IMATH_LIBRARY})

if(PROJECT_IS_TOP_LEVEL)
  find_package(GTest REQUIRED)
  find_package(benchmark REQUIRED)
  find_package(fcl REQUIRED)
endif()

if(CARIESIM_BUILD_VIEWER)
  find_package(glfw3 REQUIRED)
  pkg_check_modules(EPOXY REQUIRED IMPORTED_TARGET epoxy)
  # Dear ImGui 1.86 ships its GLFW and OpenGL3 backends inside libimgui.a; pkg-config adds -lstb.
  pkg_check_modules(IMGUI REQUIRED IMPORTED_TARGET imgui)
endif()
