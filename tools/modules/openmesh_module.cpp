// The vgeo_openmesh module's entry point: the table of its functions (openmesh_module.h).
// Linked with -Bsymbolic, so the addresses taken here are the module's own definitions and never
// the executable's forwarding stubs of the same names (tools/vgeo/openmesh_module_stub.cpp).
#include "openmesh_module.h"

extern "C" __attribute__((visibility("default"))) const vgeo::OpenMeshModule* vgeo_openmesh_module() {
  static const vgeo::OpenMeshModule table = [] {
    vgeo::OpenMeshModule t;
    t.subdivide_loop = &vgeo::subdivide_loop;
    t.simplify_openmesh = &vgeo::build_detail::simplify_openmesh;
    return t;
  }();
  return &table;
}
