// OMPL.app problems: the [problem] section of a .cfg file and its meshes, as an hgraph.v1 Scene,
// following the conventions OMPL.app's own planners use so that a configuration means the same
// robot placement here as there:
//  - meshes are found relative to the .cfg file; assimp's default up-axis handling is kept (a
//    Z_UP COLLADA file is turned Y_UP, as OMPL.app sees it) and node transforms are applied;
//  - the configuration is the position of OMPL.app's reference point of the robot (in 2D its x
//    and y only), so the robot is shifted by it: the mean of the vertices as OMPL.app's own
//    assimp import leaves them (MeshLoadOptions::ompl_app_center), where a corner shared by
//    faces of different normals counts once per normal; the collision model stays ours;
//  - 2D: space SE(2), pose Translation(x, y, 0) * RotZ(theta), start.x/y/theta;
//    3D: space SE(3), pose Translation(x, y, z) * AngleAxis(theta, axis),
//        start.x/y/z/axis.x/axis.y/axis.z/theta (same for goal);
//  - volume.min.* / volume.max.* bound the reference point; without them the bounds are the
//    world mesh's bounding box, widened by 5% on each side (OMPL.app infers them likewise);
//  - distance weights are OMPL's defaults (SE(2) rotation 0.5, SE(3) 1).
#pragma once

#include <string>
#include <vector>

#include "core/path/path.h"
#include "core/space/space.h"
#include "hgraph/v1/scene.pb.h"

namespace hgraph {

// Reads the problem. Mesh paths in the result are as written in the .cfg (relative to its
// folder unless absolute), so SceneFromProto(proto, folder of cfg_path) loads it. Errors are
// InputErrors naming "<cfg_path>: [problem].<key>", or Error(kNotFound) for a missing file.
v1::Scene ReadOmplAppProblem(const std::string& cfg_path);

// Rewrites every relative mesh path of `scene` from relative-to-`from_dir` to
// relative-to-`to_dir` (for writing the scene next to another file).
void RebaseMeshPaths(const std::string& from_dir, const std::string& to_dir, v1::Scene* scene);

// OMPL's state printout (PathGeometric::print), the format of the .path files shipped with
// OMPL.app: "Compound state [" ... "]" blocks whose lines hold "RealVectorState [x y]",
// "SO2State [theta]", "SO3State [x y z w]", or one such line per state for a single space. The
// numbers of a state are taken in order, which is our layout for SE(2) and SE(3). One path named
// after the file. A state whose count differs from the space's dimension is an InputError
// naming "source:line". (OMPL's matrix format, one state per line, is ParsePathsText's.)
// A file may hold several such paths, each from its "Geometric path with N states" line on;
// they are named "<file stem>-<i>" then.
bool LooksLikeOmplStatePrint(const std::string& text);
std::vector<InputPath> ParseOmplStatePrint(const std::string& text, const std::string& source,
                                           const Space& space);

// The paths as OMPL's PathGeometric::print prints them in `space` (the states as
// StateSpace::printState does: SE(2) = CompoundStateSpace of RealVectorStateSpace(2) and
// SO2StateSpace, SE(3) = of RealVectorStateSpace(3) and SO3StateSpace, a product of components
// a compound of those), one path after another. The only difference is the numbers: printed
// with enough digits to read back exactly, where OMPL prints the stream's precision (6 by
// default). Names are not part of the format.
std::string OmplStatePrint(const std::vector<InputPath>& paths, const Space& space);

}  // namespace hgraph
