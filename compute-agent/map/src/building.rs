//! A building: floors, each an occupancy grid with its semantic layer, and the gateways
//! (elevators, stairs, ramps) that join them (ISANA's multi-floor maps).
//!
//! # Manifest format (TOML)
//!
//! ```toml
//! [[floor]]
//! level = 0                 # unique integer, 0 = ground
//! map = "floor0.yaml"       # map_server YAML, relative to the manifest
//! semantic = "floor0.toml"  # optional semantic layer (see [`crate::semantic`])
//! elevation_m = 0.0         # optional: the floor's height, metres, for a barometer;
//!                           # on every floor or none, higher for each level up
//!
//! [[floor]]
//! level = 1
//! map = "floor1.yaml"
//! semantic = "floor1.toml"
//! elevation_m = 3.5
//! ```
//!
//! A gateway may be listed in any floor's semantic file (or in several, with the same
//! kind and stops that agree); its stops must be on floors of the building.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{line_of, MapError};
use crate::grid::OccupancyGrid;
use crate::semantic::{Gateway, SemanticLayer};

/// One floor: its level, grid and semantic layer (only that floor's items).
#[derive(Clone, Debug, PartialEq)]
pub struct Floor {
    /// integer level, 0 = ground
    pub level: i32,
    /// the floor plan
    pub grid: OccupancyGrid,
    /// labels, doors, corners and areas of this floor, gateways serving it
    pub semantic: SemanticLayer,
}

/// Floors by level plus the gateways between them.
#[derive(Clone, Debug, PartialEq)]
pub struct Building {
    floors: Vec<Floor>,
    gateways: Vec<Gateway>,
    /// each floor's height above the ground floor's, metres (all floors or none)
    elevations: BTreeMap<i32, f64>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    #[serde(rename = "floor")]
    floors: Vec<ManifestFloor>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestFloor {
    level: i32,
    map: PathBuf,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    semantic: Option<PathBuf>,
    /// the floor's height, metres (a barometer tells floors apart by it)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    elevation_m: Option<f64>,
}

impl Building {
    /// A building from its floors; gateways are gathered from the floors' semantic
    /// layers. Refuses duplicate levels, conflicting gateway entries and gateway stops
    /// on floors the building does not have. `file` names the source in errors.
    pub fn new(mut floors: Vec<Floor>, file: &Path) -> Result<Self, MapError> {
        let err = |message: String| MapError::Building { file: file.to_path_buf(), line: 0, message };
        if floors.is_empty() {
            return Err(err("a building needs at least one floor".into()));
        }
        floors.sort_by_key(|f| f.level);
        if let Some(w) = floors.windows(2).find(|w| w[0].level == w[1].level) {
            return Err(err(format!("floor level {} appears twice", w[0].level)));
        }
        let mut gateways: BTreeMap<String, Gateway> = BTreeMap::new();
        for f in &floors {
            for g in &f.semantic.gateways {
                match gateways.get(&g.name) {
                    Some(known) if known != g => {
                        return Err(err(format!("gateway '{}' is described differently on two floors", g.name)))
                    }
                    Some(_) => {}
                    None => {
                        gateways.insert(g.name.clone(), g.clone());
                    }
                }
            }
        }
        for g in gateways.values() {
            if let Some(s) = g.stops.iter().find(|s| floors.iter().all(|f| f.level != s.floor)) {
                return Err(err(format!("gateway '{}' stops on floor {}, which the building lacks", g.name, s.floor)));
            }
        }
        Ok(Self { floors, gateways: gateways.into_values().collect(), elevations: BTreeMap::new() })
    }

    /// The building with each floor's height (metres, any common zero): all floors or
    /// none, finite, and higher for each level up. `file` names the source in errors.
    pub fn with_elevations(mut self, elevations: &[(i32, f64)], file: &Path) -> Result<Self, MapError> {
        let err = |message: String| MapError::Building { file: file.to_path_buf(), line: 0, message };
        let mut map = BTreeMap::new();
        for &(level, m) in elevations {
            if self.floor(level).is_none() {
                return Err(err(format!("an elevation is given for floor {level}, which the building lacks")));
            }
            if !m.is_finite() {
                return Err(err(format!("floor {level}'s elevation {m} is no height")));
            }
            if map.insert(level, m).is_some() {
                return Err(err(format!("floor {level}'s elevation is given twice")));
            }
        }
        if !map.is_empty() {
            if let Some(f) = self.floors.iter().find(|f| !map.contains_key(&f.level)) {
                return Err(err(format!("floor {} has no elevation_m: give it for every floor or for none", f.level)));
            }
            let by_level: Vec<(i32, f64)> = map.iter().map(|(l, m)| (*l, *m)).collect();
            if let Some(w) = by_level.windows(2).find(|w| w[1].1 <= w[0].1) {
                return Err(err(format!(
                    "floor {} ({} m) is not above floor {} ({} m)",
                    w[1].0, w[1].1, w[0].0, w[0].1
                )));
            }
        }
        self.elevations = map;
        Ok(self)
    }

    /// The height of floor `level`, metres, when the map gives floors' heights.
    pub fn elevation(&self, level: i32) -> Option<f64> {
        self.elevations.get(&level).copied()
    }

    /// Loads a building manifest and every map and semantic file it names.
    pub fn load(manifest_path: &Path) -> Result<Self, MapError> {
        let bytes = crate::map_server::read_limited(manifest_path)?;
        let text = String::from_utf8_lossy(&bytes);
        let manifest: Manifest = toml::from_str(&text).map_err(|e| MapError::Building {
            file: manifest_path.to_path_buf(),
            line: e.span().map_or(0, |s| line_of(&text, s.start)),
            message: e.message().to_string(),
        })?;
        let dir = manifest_path.parent().unwrap_or(Path::new("."));
        let mut floors = Vec::with_capacity(manifest.floors.len());
        let elevations: Vec<(i32, f64)> =
            manifest.floors.iter().filter_map(|mf| mf.elevation_m.map(|m| (mf.level, m))).collect();
        for mf in manifest.floors {
            let grid = crate::map_server::load_map(&dir.join(&mf.map))?;
            let semantic = match &mf.semantic {
                Some(p) => SemanticLayer::load(&dir.join(p))?,
                None => SemanticLayer::default(),
            };
            if let Some(item) = misplaced(&semantic, mf.level) {
                return Err(MapError::Semantic {
                    file: mf.semantic.clone().unwrap_or_default(),
                    line: 0,
                    message: format!("{item} is not on floor {}, the floor this file belongs to", mf.level),
                });
            }
            floors.push(Floor { level: mf.level, grid, semantic });
        }
        Self::new(floors, manifest_path)?.with_elevations(&elevations, manifest_path)
    }

    /// Writes the manifest at `manifest_path` and, beside it, `floor<level>.yaml/.pgm/.toml`.
    pub fn write(&self, manifest_path: &Path) -> Result<(), MapError> {
        let dir = manifest_path.parent().unwrap_or(Path::new("."));
        let io = |file: PathBuf| move |source| MapError::Io { file, action: "cannot write", source };
        let mut manifest = Manifest { floors: Vec::new() };
        for f in &self.floors {
            let stem = format!("floor{}", f.level);
            crate::map_server::write_map(&f.grid, &dir.join(format!("{stem}.yaml")))?;
            let semantic = PathBuf::from(format!("{stem}.toml"));
            std::fs::write(dir.join(&semantic), f.semantic.to_toml()).map_err(io(dir.join(&semantic)))?;
            manifest.floors.push(ManifestFloor {
                level: f.level,
                map: PathBuf::from(format!("{stem}.yaml")),
                semantic: Some(semantic),
                elevation_m: self.elevation(f.level),
            });
        }
        let text = toml::to_string(&manifest).unwrap_or_default();
        std::fs::write(manifest_path, text).map_err(io(manifest_path.to_path_buf()))
    }

    /// All floors, by increasing level.
    pub fn floors(&self) -> &[Floor] {
        &self.floors
    }

    /// The floor at `level`, if any.
    pub fn floor(&self, level: i32) -> Option<&Floor> {
        self.floors.iter().find(|f| f.level == level)
    }

    /// Every gateway in the building, by name.
    pub fn gateways(&self) -> &[Gateway] {
        &self.gateways
    }
}

/// The first item of a per-floor file that belongs to another floor.
fn misplaced(s: &SemanticLayer, level: i32) -> Option<String> {
    s.labels
        .iter()
        .find(|l| l.floor != level)
        .map(|l| format!("label '{}'", l.name))
        .or_else(|| s.doors.iter().find(|d| d.floor != level).map(|d| format!("door '{}'", d.number)))
        .or_else(|| s.corners.iter().find(|c| c.floor != level).map(|c| format!("corner at ({}, {})", c.x, c.y)))
        .or_else(|| s.areas.iter().find(|a| a.floor != level).map(|a| format!("area '{}'", a.name)))
        .or_else(|| s.gateways.iter().find(|g| g.stop(level).is_none()).map(|g| format!("gateway '{}'", g.name)))
}
