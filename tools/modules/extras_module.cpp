// The vgeo_extras module's entry point: the table of its functions (extras_module.h).
// Linked with -Bsymbolic, so the addresses taken here are the module's own definitions and never
// the executable's forwarding stubs of the same names (tools/vgeo/extras_module_stub.cpp).
#include "extras_module.h"

extern "C" __attribute__((visibility("default"))) const vgeo::ExtrasModule* vgeo_extras_module() {
  static const vgeo::ExtrasModule table = [] {
    vgeo::ExtrasModule t;
    t.subdivide_loop = &vgeo::subdivide_loop;
    t.simplify_openmesh = &vgeo::build_detail::simplify_openmesh;
    t.import_gltf = &vgeo::detail::import_gltf;
    t.write_png = &vgeo::write_png;
    return t;
  }();
  return &table;
}
