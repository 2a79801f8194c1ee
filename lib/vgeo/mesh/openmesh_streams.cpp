#include "vgeo/mesh/openmesh_streams.h"

#include <OpenMesh/Core/System/omstream.hh>

namespace vgeo {

void silence_openmesh_streams() {
  // A function-local static is initialised exactly once, and every later caller sees it
  // complete (C++11 thread-safe initialisation): the streams' own lazy set-up runs here only.
  static const bool silenced = [] {
    omlog().disable();
    omout().disable();
    omerr().disable();
    return true;
  }();
  (void)silenced;
}

}  // namespace vgeo
