# The physics engines, from Debian's packages.

# MuJoCo 2.2.2: Debian's exported target names /usr/include/libqhull_r/, which is not
# installed, so configuring fails until that entry is removed from the include list.
find_package(mujoco 2.2 REQUIRED)
get_target_property(_mujoco_includes mujoco::mujoco INTERFACE_INCLUDE_DIRECTORIES)
list(FILTER _mujoco_includes EXCLUDE REGEX "qhull")
set_target_properties(mujoco::mujoco PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_mujoco_includes}")

# Bullet 3.24, float64 build. A plain find_package(Bullet) would silently link the float build.
find_package(PkgConfig REQUIRED)
pkg_check_modules(BULLET64 REQUIRED IMPORTED_TARGET bullet-float64)

# Simbody 3.7: its own CMake package (SimTKsimbody, SimTKmath, SimTKcommon).
find_package(Simbody 3.7 REQUIRED CONFIG)
# ODE 0.16, double precision (Debian's libode-dev; the engine refuses another build at start-up).
# No CMake package: pkg-config.
pkg_check_modules(ODE REQUIRED IMPORTED_TARGET ode)
