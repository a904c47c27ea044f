# The installed surface (docs/architecture.md, "Public surface"): the headers users call, and the
# public headers they include, computed here. Nothing else of include/cariesim/ is installed.

# What users call, under include/: the scene and the model builder, the model, the step and its
# running parameters, the session and the servo loop, the devices (the replay device among them) and
# the device factory, the recorder and a recording's replay, training's run, study and report; and
# the error every call throws.
set(CARIESIM_PUBLIC_HEADERS
  cariesim/common/error.hpp
  cariesim/scene/scene.hpp
  cariesim/device/trajectory_csv.hpp
  cariesim/scene/model_builder.hpp
  cariesim/render/model.hpp
  cariesim/render/step.hpp
  cariesim/render/params.hpp
  cariesim/servo/session.hpp
  cariesim/servo/servo.hpp
  cariesim/device/factory.hpp
  cariesim/device/device.hpp
  cariesim/device/devices.hpp
  cariesim/device/udp_device.hpp
  cariesim/device/replay.hpp
  cariesim/device/haptic_device.hpp
  cariesim/device/hardware_backends.hpp
  cariesim/record/recorder.hpp
  cariesim/record/replay.hpp
  cariesim/training/run.hpp
  cariesim/training/study.hpp
  cariesim/training/report.hpp)

# Sets `out` to `roots` and every header under `include_dir` that they include
# (`#include "cariesim/..."`), transitively, sorted. A header that names a missing one is an error.
function(cariesim_header_closure out include_dir)
  set(todo ${ARGN})
  set(seen)
  while(todo)
    list(POP_FRONT todo header)
    if(header IN_LIST seen)
      continue()
    endif()
    if(NOT EXISTS ${include_dir}/${header})
      message(FATAL_ERROR "public surface: ${include_dir}/${header} does not exist")
    endif()
    list(APPEND seen ${header})
    file(STRINGS ${include_dir}/${header} includes REGEX "^[ \t]*#[ \t]*include[ \t]*\"cariesim/")
    foreach(line IN LISTS includes)
      string(REGEX REPLACE "^[^\"]*\"(cariesim/[^\"]+)\".*$" "\\1" included "${line}")
      list(APPEND todo ${included})
    endforeach()
  endwhile()
  list(SORT seen)
  set(${out} ${seen} PARENT_SCOPE)
endfunction()
