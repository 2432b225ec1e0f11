#pragma once
/// \file
/// Initial particle arrangements: square lattices, concentric rings, and wall/dummy layers around them.
#include "mps/core/particles.hpp"

namespace mps {

/// An axis-aligned rectangle [x0, x1] x [y0, y1].
struct Rect {
  /// @{ lower-left (x0, y0) and upper-right (x1, y1) corners [m]
  double x0, y0, x1, y1;  /// @}
};

/// Square lattice filling rect; points sit at cell centres, (x0 + (i + 1/2) l0, y0 + (j + 1/2) l0), so two
/// rectangles sharing an edge tile without overlap.
void fill_rectangle(Particles& particles, Rect rect, double l0, Kind kind, int group = 0);

/// Sides of a rectangle, combined with |, e.g. `left | right | bottom` for a tank open at the top.
enum Side : unsigned { left = 1u, right = 2u, bottom = 4u, top = 8u };

/// Adds boundary layers outside `inner` on the given sides (corners between walled sides included), on the
/// same lattice as fill_rectangle: the first `wall_layers` layers are Kind::wall, the next `dummy_layers`
/// are Kind::dummy. An unwalled side stays open (e.g. a tank's top).
void add_rectangle_walls(Particles& particles, Rect inner, double l0, unsigned sides, int wall_layers,
                         int dummy_layers, int group = 0);

/// An axis-aligned box [x0, x1] x [y0, y1] x [z0, z1] (3-D).
struct Box {
  /// @{ lower corner (x0, y0, z0) and upper corner (x1, y1, z1) [m]
  double x0, y0, z0, x1, y1, z1;  /// @}
};

/// Cubic lattice filling box; points sit at cell centres, as fill_rectangle's.
void fill_box(Particles3& particles, Box box, double l0, Kind kind, int group = 0);

/// A 2-D layout extruded along z: `layers` copies of `layer` at z = z0 + (k + 1/2) l0, k = 0, ..., layers - 1, with
/// its kinds and groups, layer by layer (a periodic slab of a planar flow, a prism of a 2-D shape).
Particles3 extrude(const Particles& layer, double z0, double l0, int layers);

/// Faces of a box, combined with |, e.g. everything but z_high for a tank open at the top (gravity along -z). The
/// first four have the values of the rectangle's sides.
enum Face : unsigned { x_low = 1u, x_high = 2u, y_low = 4u, y_high = 8u, z_low = 16u, z_high = 32u };

/// Adds boundary layers outside `inner` on the given faces (edges and corners between walled faces included), on the
/// lattice of fill_box: the first `wall_layers` layers are Kind::wall, the next `dummy_layers` Kind::dummy.
void add_box_walls(Particles3& particles, Box inner, double l0, unsigned faces, int wall_layers, int dummy_layers,
                   int group = 0);

/// How fill_annular_sector places particles.
enum class Lattice { square, rings };

/// Fills r0 <= r < r1, theta0 <= theta < theta1 (radians, counter-clockwise) about (cx, cy).
/// rings: ring k at r0 + (k + 1/2) l0 with round(r * span / l0) evenly spaced particles;
/// square: the cell-centred square lattice clipped to the sector.
void fill_annular_sector(Particles& particles, double r0, double r1, double theta0, double theta1, double l0,
                         Kind kind, Lattice lattice, int group = 0, double cx = 0.0, double cy = 0.0);

/// Groups of a walled annulus's particles.
struct AnnulusGroups {
  /// @{ the fluid's, the inner wall's, the outer wall's and the flights' group
  int fluid = 0, inner = 1, outer = 2, flights = 3;  /// @}
};

/// A walled annulus about the origin on concentric rings (seed 000's layout, docs/rotating.md): fluid rings k = 0, ...,
/// rings - 1 at r = r_inner + (k + 1/2) l0, then wall_layers rings of Kind::wall and dummy_layers of Kind::dummy
/// inside them (group `inner`) and outside (group `outer`), in order of k. With span < 2 pi, the sector of `span`
/// radians centred on the angle `centre`, closed at both ends by radial flights of as many layers (group `flights`);
/// each ring then holds annulus_ring_count particles over the opening and carries on at their spacing into the flights.
void fill_walled_annulus(Particles& particles, double r_inner, int rings, double l0, int wall_layers, int dummy_layers,
                         double span, double centre, AnnulusGroups groups = {});
/// Particles a ring of radius r holds over an opening of `span` radians: round(r span / l0), at least 1.
int annulus_ring_count(double r, double span, double l0);

}  // namespace mps
