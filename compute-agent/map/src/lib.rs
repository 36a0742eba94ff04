//! Floor maps for localization and route planning: pure, no bus, no runtime, no clock.
//!
//! | what | module | source |
//! | --- | --- | --- |
//! | occupancy grid (free / occupied / unknown) in the map frame | [`grid`] | ROS `nav_msgs/OccupancyGrid` |
//! | read and write the ROS `map_server` format (YAML + PGM/PNG) | [`map_server`], [`pgm`] | ROS wiki `map_server` |
//! | labels, numbered doors, corners, areas, gateways | [`semantic`] | ISANA; Zhang et al. (landmarks) |
//! | floors + gateways | [`building`] | ISANA (multi-floor) |
//! | a CAD floor plan (DXF) as a grid and labels | [`dxf`] | AutoCAD DXF reference |
//! | Euclidean distance field, inflation | [`distance`] | Felzenszwalb & Huttenlocher 2012 |
//!
//! Bad input is a [`MapError`] naming the file (and line where the parser has one);
//! sizes are checked against [`MAX_CELLS`] and [`map_server::MAX_FILE_BYTES`] before
//! anything large is allocated.

pub mod building;
pub mod distance;
pub mod dxf;
pub mod error;
pub mod grid;
pub mod map_server;
pub mod pgm;
pub mod semantic;

pub use building::{Building, Floor};
pub use distance::{inflate, DistanceField};
pub use dxf::{DxfFloor, DxfImport, DxfReport, Units};
pub use error::MapError;
pub use grid::{Cell, OccupancyGrid, Origin, MAX_CELLS, MAX_RESOLUTION_M};
pub use map_server::{load_map, write_map, MapMetadata, MapMode};
pub use semantic::{Area, Corner, Door, Gateway, GatewayKind, GatewayStop, Label, SemanticLayer};
