# The comparator knows no engine (docs/design.md, "Layout"): crosslink_compare links nothing from
# sim/ (checked here, at configure time, over its whole link closure) and compare/ includes nothing
# from sim/ or methods/ (the test layering.compare_includes, cmake/check_includes.cmake).

# Every target `target` links, directly or through another target, into `out`.
function(crosslink_link_closure target out)
  set(seen "${${out}}")
  foreach(property LINK_LIBRARIES INTERFACE_LINK_LIBRARIES)
    get_target_property(libs ${target} ${property})
    if(NOT libs)
      continue()
    endif()
    foreach(lib IN LISTS libs)
      if(TARGET ${lib})
        get_target_property(real ${lib} ALIASED_TARGET)
        if(real)
          set(lib ${real})
        endif()
        if(NOT lib IN_LIST seen)
          list(APPEND seen ${lib})
          crosslink_link_closure(${lib} seen)
        endif()
      endif()
    endforeach()
  endforeach()
  set(${out} "${seen}" PARENT_SCOPE)
endfunction()

set(_compare_links "")
crosslink_link_closure(crosslink_compare _compare_links)
foreach(_forbidden crosslink_sim crosslink_mujoco crosslink_bullet crosslink_ode crosslink_simbody
                   crosslink_methods mujoco::mujoco PkgConfig::BULLET64 PkgConfig::ODE)
  if(TARGET ${_forbidden} AND _forbidden IN_LIST _compare_links)
    message(FATAL_ERROR "crosslink_compare links ${_forbidden}: the comparator must know no engine "
                        "(docs/design.md, \"Layout\")")
  endif()
endforeach()
