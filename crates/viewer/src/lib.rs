//! octoarm's viewer. `raster` (always built, no dependencies): a small software rasteriser for
//! frames rendered without a display (the Gymnasium environments' `rgb_array`). With the
//! `server` feature (default): the local web server of `octoarm view` and `octoarm run --view`
//! (`server`), the page and its vendored three.js embedded in the binary, reading run folders
//! (`runs`, `npz`, `scene`) and the live stream of a running simulation (`live`).

pub mod raster;

#[cfg(feature = "server")]
pub mod blob;
#[cfg(feature = "server")]
pub mod live;
#[cfg(feature = "server")]
pub mod npz;
#[cfg(feature = "server")]
pub mod runs;
#[cfg(feature = "server")]
pub mod scene;
#[cfg(feature = "server")]
pub mod server;
