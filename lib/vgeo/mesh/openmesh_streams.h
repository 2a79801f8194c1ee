#pragma once
// OpenMesh reports through three process-wide streams, omlog/omout/omerr (to clog/cout/cerr):
// e.g. "PolyMeshT::add_face: complex edge" when a face cannot be added. vgeo handles every
// such case itself (lib/vgeo/dag/simplify.cpp passes those faces through, lib/vgeo/mesh/
// subdivide.cpp refuses them with a code), so the chatter must never reach the user.
//
// Call before any OpenMesh use (cheap after the first call, safe from any thread): the first
// call initialises the three streams and disables them, once. Besides the silence this
// serialises their initialisation: OpenMesh initialises each stream on first use behind a
// plain bool, so threads using one first at the same time each connect it to the standard
// stream (std::map and std::vector insertions racing; seen as lines written 2-3 times).
// The streams are process-wide, so this also silences OpenMesh for a host program using it.
namespace vgeo {

void silence_openmesh_streams();

}  // namespace vgeo
