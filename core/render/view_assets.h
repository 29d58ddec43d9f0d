// The scripts and style the 3D view inlines into every file it writes: three.js (with its
// OrbitControls) as one classic script defining the global THREE, the page's own script
// (core/render/view/view.js) and its style sheet. Generated at build time by
// core/render/view/embed_assets.py from the pinned npm package `three`.
#pragma once

namespace hgraph::view_assets {

extern const char kThreeVersion[];
extern const char kThreeJs[];
extern const char kPageJs[];
extern const char kPageCss[];

}  // namespace hgraph::view_assets
