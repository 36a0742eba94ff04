//! The semantic layer: what a floor plan means to a person, beside the occupancy grid.
//! Labels ("room 214", "toilets"), numbered doors (Zhang et al.'s unique landmarks),
//! corridor corners (their non-unique landmarks), areas as a tree (ISANA's "where am
//! I": room inside wing inside floor) and gateways between floors (ISANA's elevators
//! and stairs).
//!
//! # File format (TOML)
//!
//! Coordinates are metres in the map frame of the floor named by `floor` (an integer
//! level, 0 = ground). Every table is optional.
//!
//! ```toml
//! north_deg = 90.0      # where a compass's north lies on the map: degrees counter-
//!                       # clockwise from the map's +x axis (90: north is up, +y)
//!
//! [[label]]
//! name = "room 214"
//! x = 12.5
//! y = 3.0
//! floor = 2
//!
//! [[door]]
//! number = "214"        # unique on its floor: a door sign is a unique landmark
//! x = 12.0
//! y = 2.0
//! floor = 2
//! normal = [0.0, 1.0]   # the wall's normal, pointing into the corridor (normalised on load)
//!
//! [[corner]]
//! x = 20.0
//! y = 2.0
//! floor = 2
//!
//! [[area]]
//! name = "east wing"
//! floor = 2
//! polygon = [[10.0, 0.0], [30.0, 0.0], [30.0, 20.0], [10.0, 20.0]]
//!
//! [[area]]
//! name = "room 214"
//! floor = 2
//! parent = "east wing"  # must be an area of the same floor; no cycles
//! polygon = [[11.0, 2.0], [14.0, 2.0], [14.0, 5.0], [11.0, 5.0]]
//!
//! [[gateway]]
//! name = "main elevator"
//! type = "elevator"     # elevator | stairs | ramp
//! stops = [ { floor = 0, x = 5.0, y = 5.0 }, { floor = 2, x = 5.0, y = 5.2 } ]
//! ```
//!
//! A gateway joins the floors of its stops (at least two, one stop per floor).

use std::collections::{HashMap, HashSet};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{line_of, MapError};

/// A named place a user can ask for.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Label {
    /// what the user says or hears
    pub name: String,
    /// metres, map frame
    pub x: f64,
    /// metres, map frame
    pub y: f64,
    /// floor level
    pub floor: i32,
}

/// A door with a number sign: a unique landmark.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Door {
    /// the number on its sign (text: "214", "B1.07")
    pub number: String,
    /// metres, map frame
    pub x: f64,
    /// metres, map frame
    pub y: f64,
    /// floor level
    pub floor: i32,
    /// unit normal of the wall it is in, map frame
    pub normal: [f64; 2],
}

/// A corridor corner: a landmark that is not unique.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Corner {
    /// metres, map frame
    pub x: f64,
    /// metres, map frame
    pub y: f64,
    /// floor level
    pub floor: i32,
}

/// A named region; areas nest through `parent`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Area {
    /// unique per floor
    pub name: String,
    /// floor level
    pub floor: i32,
    /// vertices in order (at least three), metres, map frame
    pub polygon: Vec<[f64; 2]>,
    /// the enclosing area's name, if any
    #[serde(default)]
    pub parent: Option<String>,
}

/// What kind of passage a gateway is (user preferences weigh them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GatewayKind {
    /// a lift
    Elevator,
    /// a staircase
    Stairs,
    /// a ramp
    Ramp,
}

/// Where a gateway is on one floor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GatewayStop {
    /// floor level
    pub floor: i32,
    /// metres, that floor's map frame
    pub x: f64,
    /// metres, that floor's map frame
    pub y: f64,
}

/// A passage between floors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gateway {
    /// unique in the building
    pub name: String,
    /// elevator, stairs or ramp (`type` in the file)
    #[serde(rename = "type")]
    pub kind: GatewayKind,
    /// one per floor it serves (at least two)
    pub stops: Vec<GatewayStop>,
}

impl Gateway {
    /// The floors it joins, in the order of its stops.
    pub fn floors(&self) -> Vec<i32> {
        self.stops.iter().map(|s| s.floor).collect()
    }

    /// Its stop on `floor`, if it serves that floor.
    pub fn stop(&self, floor: i32) -> Option<&GatewayStop> {
        self.stops.iter().find(|s| s.floor == floor)
    }
}

/// Everything a semantic file holds.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SemanticLayer {
    /// named places
    #[serde(default, rename = "label")]
    pub labels: Vec<Label>,
    /// numbered doors
    #[serde(default, rename = "door")]
    pub doors: Vec<Door>,
    /// corridor corners
    #[serde(default, rename = "corner")]
    pub corners: Vec<Corner>,
    /// the tree of areas
    #[serde(default, rename = "area")]
    pub areas: Vec<Area>,
    /// passages between floors
    #[serde(default, rename = "gateway")]
    pub gateways: Vec<Gateway>,
    /// where a compass's (magnetic) north lies on the map, degrees counter-clockwise
    /// from the map's +x axis, 0..360 (90: north is +y). `None`: unknown, and a phone's
    /// compass cannot be read against the map. One value for the whole building.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub north_deg: Option<f64>,
}

impl SemanticLayer {
    /// Reads and checks a semantic file.
    pub fn load(path: &Path) -> Result<Self, MapError> {
        let bytes = crate::map_server::read_limited(path)?;
        let text = String::from_utf8(bytes).map_err(|e| MapError::Semantic {
            file: path.to_path_buf(),
            line: line_of(&String::from_utf8_lossy(e.as_bytes()), e.utf8_error().valid_up_to()),
            message: "not UTF-8 text".into(),
        })?;
        Self::parse(&text, path)
    }

    /// Parses and checks a semantic file's text; `file` names it in errors.
    pub fn parse(text: &str, file: &Path) -> Result<Self, MapError> {
        let layer: Self = toml::from_str(text).map_err(|e| MapError::Semantic {
            file: file.to_path_buf(),
            line: e.span().map_or(0, |s| line_of(text, s.start)),
            message: e.message().to_string(),
        })?;
        layer.validated(file)
    }

    /// Writes the layer as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    /// The layer restricted to one floor (gateways serving it included whole).
    pub fn floor(&self, floor: i32) -> Self {
        Self {
            labels: self.labels.iter().filter(|l| l.floor == floor).cloned().collect(),
            doors: self.doors.iter().filter(|d| d.floor == floor).cloned().collect(),
            corners: self.corners.iter().filter(|c| c.floor == floor).cloned().collect(),
            areas: self.areas.iter().filter(|a| a.floor == floor).cloned().collect(),
            gateways: self.gateways.iter().filter(|g| g.stop(floor).is_some()).cloned().collect(),
            north_deg: self.north_deg,
        }
    }

    /// Map heading (radians, counter-clockwise from +x) of a compass heading (degrees
    /// clockwise from north), with this layer's north; `None` without one.
    pub fn map_heading_rad(&self, compass_deg: f64) -> Option<f64> {
        self.north_deg.map(|north| map_heading_rad(north, compass_deg))
    }

    /// The label called `name` (case-insensitive), if any.
    pub fn label(&self, name: &str) -> Option<&Label> {
        self.labels.iter().find(|l| l.name.eq_ignore_ascii_case(name))
    }

    /// The door numbered `number` on `floor`, if any.
    pub fn door(&self, floor: i32, number: &str) -> Option<&Door> {
        self.doors.iter().find(|d| d.floor == floor && d.number == number)
    }

    /// The areas containing (x, y) on `floor`, innermost first, then its parents up to
    /// the root: "room 214, east wing".
    pub fn areas_at(&self, floor: i32, x: f64, y: f64) -> Vec<&Area> {
        let inside: Vec<&Area> =
            self.areas.iter().filter(|a| a.floor == floor && point_in_polygon(&a.polygon, x, y)).collect();
        // the innermost is the containing area that no other containing area names as parent
        let Some(innermost) =
            inside.iter().find(|a| !inside.iter().any(|b| b.parent.as_deref() == Some(a.name.as_str())))
        else {
            return Vec::new();
        };
        let mut chain = vec![*innermost];
        while let Some(parent) = chain.last().and_then(|a| a.parent.as_deref()) {
            match self.areas.iter().find(|a| a.floor == floor && a.name == parent) {
                Some(p) if chain.len() <= self.areas.len() => chain.push(p),
                _ => break,
            }
        }
        chain
    }

    fn validated(mut self, file: &Path) -> Result<Self, MapError> {
        let err = |message: String| MapError::Semantic { file: file.to_path_buf(), line: 0, message };
        if let Some(north) = self.north_deg {
            if !north.is_finite() {
                return Err(err(format!("north_deg must be a finite angle in degrees (got {north})")));
            }
            self.north_deg = Some(north.rem_euclid(360.0));
        }
        let finite = |what: &str, v: &[f64]| {
            if v.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                Err(err(format!("{what}: coordinates must be finite numbers")))
            }
        };
        for l in &self.labels {
            finite(&format!("label '{}'", l.name), &[l.x, l.y])?;
            if l.name.trim().is_empty() {
                return Err(err("a label has an empty name".into()));
            }
        }
        let mut door_numbers = HashSet::new();
        for d in &mut self.doors {
            finite(&format!("door '{}'", d.number), &[d.x, d.y, d.normal[0], d.normal[1]])?;
            let n = d.normal[0].hypot(d.normal[1]);
            if n < 1e-9 {
                return Err(err(format!("door '{}': the wall normal must not be zero", d.number)));
            }
            d.normal = [d.normal[0] / n, d.normal[1] / n];
            if !door_numbers.insert((d.floor, d.number.clone())) {
                return Err(err(format!(
                    "door '{}' appears twice on floor {}: door numbers are unique",
                    d.number, d.floor
                )));
            }
        }
        for c in &self.corners {
            finite("corner", &[c.x, c.y])?;
        }
        let mut names = HashMap::new();
        for a in &self.areas {
            if a.polygon.len() < 3 {
                return Err(err(format!("area '{}': a polygon needs at least 3 points", a.name)));
            }
            finite(&format!("area '{}'", a.name), &a.polygon.iter().flatten().copied().collect::<Vec<_>>())?;
            if names.insert((a.floor, a.name.as_str()), a).is_some() {
                return Err(err(format!("area '{}' appears twice on floor {}", a.name, a.floor)));
            }
        }
        for a in &self.areas {
            let mut seen = HashSet::from([a.name.as_str()]);
            let mut cur = a;
            while let Some(p) = cur.parent.as_deref() {
                cur = *names.get(&(a.floor, p)).ok_or_else(|| {
                    err(format!("area '{}': parent '{p}' is not an area of floor {}", a.name, a.floor))
                })?;
                if !seen.insert(p) {
                    return Err(err(format!("area '{}': its parents form a cycle through '{p}'", a.name)));
                }
            }
        }
        let mut gateway_names = HashSet::new();
        for g in &self.gateways {
            if !gateway_names.insert(g.name.as_str()) {
                return Err(err(format!("gateway '{}' appears twice", g.name)));
            }
            for s in &g.stops {
                finite(&format!("gateway '{}'", g.name), &[s.x, s.y])?;
            }
            let floors: HashSet<i32> = g.stops.iter().map(|s| s.floor).collect();
            if floors.len() != g.stops.len() || floors.len() < 2 {
                return Err(err(format!(
                    "gateway '{}': needs stops on at least two floors, one per floor (got floors {:?})",
                    g.name,
                    g.floors()
                )));
            }
        }
        Ok(self)
    }
}

/// Map heading (radians, counter-clockwise from +x) of a compass heading (degrees
/// clockwise from north) on a map whose north lies at `north_deg` (degrees
/// counter-clockwise from +x, [`SemanticLayer::north_deg`]).
pub fn map_heading_rad(north_deg: f64, compass_deg: f64) -> f64 {
    (north_deg - compass_deg).to_radians()
}

/// Even-odd rule; points on an edge may fall either way.
pub fn point_in_polygon(polygon: &[[f64; 2]], x: f64, y: f64) -> bool {
    let mut inside = false;
    let n = polygon.len();
    for i in 0..n {
        let [xi, yi] = polygon[i];
        let [xj, yj] = polygon[(i + n - 1) % n];
        if (yi > y) != (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi {
            inside = !inside;
        }
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The layer of the module documentation (also a seed of the decoder tests).
    const SAMPLE: &str = include_str!("../tests/data/sample.semantic.toml");

    fn parse(text: &str) -> Result<SemanticLayer, MapError> {
        SemanticLayer::parse(text, Path::new("floor.toml"))
    }

    #[test]
    fn sample_parses_with_normalised_door_normal() {
        let s = parse(SAMPLE).unwrap();
        assert_eq!(s.labels.len(), 1);
        assert_eq!(s.door(2, "214").unwrap().normal, [0.0, 1.0]);
        assert_eq!(s.corners[0].x, 20.0);
        assert_eq!(s.gateways[0].kind, GatewayKind::Elevator);
        assert_eq!(s.gateways[0].floors(), vec![0, 2]);
        assert_eq!(s.label("ROOM 214").unwrap().x, 12.5);
    }

    #[test]
    fn areas_at_names_the_innermost_then_its_parents() {
        let s = parse(SAMPLE).unwrap();
        let names: Vec<&str> = s.areas_at(2, 12.0, 3.0).iter().map(|a| a.name.as_str()).collect();
        assert_eq!(names, ["room 214", "east wing"]);
        let names: Vec<&str> = s.areas_at(2, 20.0, 10.0).iter().map(|a| a.name.as_str()).collect();
        assert_eq!(names, ["east wing"]);
        assert!(s.areas_at(2, 0.0, 0.0).is_empty());
        assert!(s.areas_at(1, 12.0, 3.0).is_empty());
    }

    #[test]
    fn round_trips_through_toml() {
        let s = parse(SAMPLE).unwrap();
        assert_eq!(parse(&s.to_toml()).unwrap(), s);
    }

    #[test]
    fn floor_keeps_only_that_floor_and_its_gateways() {
        let s = parse(SAMPLE).unwrap();
        assert_eq!(s.floor(0).labels.len(), 0);
        assert_eq!(s.floor(0).gateways.len(), 1);
        assert_eq!(s.floor(1).gateways.len(), 0);
        assert_eq!(s.floor(2).areas.len(), 2);
        assert_eq!(s.floor(1).north_deg, Some(100.0), "north is the building's");
    }

    #[test]
    fn north_turns_a_compass_heading_into_a_map_heading_and_must_be_an_angle() {
        let s = parse(SAMPLE).unwrap();
        // north is 100 degrees from +x: a compass's north is the map's 100 degrees, its
        // east (90 clockwise) the map's 10 degrees
        assert!((s.map_heading_rad(0.0).unwrap() - 100f64.to_radians()).abs() < 1e-12);
        assert!((s.map_heading_rad(90.0).unwrap() - 10f64.to_radians()).abs() < 1e-12);
        assert_eq!(SemanticLayer::default().map_heading_rad(0.0), None, "no north, no map heading");
        assert_eq!(parse("north_deg = -90.0\n").unwrap().north_deg, Some(270.0));
        let e = parse("north_deg = nan\n").unwrap_err().to_string();
        assert!(e.contains("north_deg must be a finite angle"), "{e}");
    }

    #[test]
    fn syntax_errors_name_the_line() {
        let text = "[[label]]\nname = \"a\"\nx = 1.0\ny = oops\nfloor = 0\n";
        let e = parse(text).unwrap_err();
        assert!(matches!(e, MapError::Semantic { line: 4, .. }), "{e}");
        assert!(e.to_string().starts_with("floor.toml:4: malformed semantic layer"), "{e}");
        let unknown = parse("[[label]]\nname = \"a\"\nx = 1.0\ny = 2.0\nfloor = 0\ncolour = 3\n").unwrap_err();
        assert!(unknown.to_string().contains("colour"), "{unknown}");
    }

    #[test]
    fn inconsistent_layers_are_refused() {
        let cases = [
            (SAMPLE.replace("parent = \"east wing\"", "parent = \"west wing\""), "not an area"),
            (SAMPLE.replace("normal = [0.0, 2.0]", "normal = [0.0, 0.0]"), "normal"),
            (
                format!("{SAMPLE}\n[[door]]\nnumber = \"214\"\nx = 1.0\ny = 1.0\nfloor = 2\nnormal = [1.0, 0.0]\n"),
                "twice",
            ),
            (SAMPLE.replace("{ floor = 2, x = 5.0, y = 5.2 }", "{ floor = 0, x = 5.0, y = 5.2 }"), "two floors"),
            (
                SAMPLE.replace("[[11.0, 2.0], [14.0, 2.0], [14.0, 5.0], [11.0, 5.0]]", "[[11.0, 2.0], [14.0, 2.0]]"),
                "3 points",
            ),
            (SAMPLE.replace("x = 12.5", "x = nan"), "finite"),
            (SAMPLE.replace("type = \"elevator\"", "type = \"escalator\""), "escalator"),
            (
                SAMPLE.replace(
                    "name = \"east wing\"\nfloor = 2\n",
                    "name = \"east wing\"\nfloor = 2\nparent = \"room 214\"\n",
                ),
                "cycle",
            ),
        ];
        for (text, why) in cases {
            let e = parse(&text).unwrap_err();
            assert!(e.to_string().contains(why), "expected '{why}' in: {e}");
        }
    }
}
