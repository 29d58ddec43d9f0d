// The scripts and style the 3D view inlines into every file it writes: three.js (with its
// OrbitControls) as one classic script defining the global THREE, the page's own script
// (core/render/view/view.js) and its style sheet. Generated at build time by
// core/render/view/embed_assets.py from the pinned npm package `three`.
#pragma once

namespace hgraph::view_assets {

// Each text is split in parts (a literal of the whole would be longer than C++ compilers must
// support), in order, ending with nullptr.
extern const char kThreeVersion[];
extern const char* const kThreeJs[];
extern const char* const kPageJs[];
extern const char* const kPageCss[];

}  // namespace hgraph::view_assets
