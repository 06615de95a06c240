//! World files: reading, parsing and checking them. A world is checked by compiling it into the board's
//! plan ([`crate::board`]), so that what the board would refuse is an error with its line when the file
//! is read.

use crate::world::{line_of, World, WorldError};
use std::path::Path;

impl World {
    /// Parses and checks a world file's text.
    pub fn from_toml_str(source: &str) -> Result<World, WorldError> {
        let world: World = toml::from_str(source).map_err(|e| {
            let offset = e.span().map(|s| s.start);
            WorldError {
                file: None,
                key: offset.and_then(|o| key_at(source, o)),
                line: offset.map(|o| line_of(source, o)),
                message: e.message().trim().to_string(),
            }
        })?;
        crate::board::Plan::compile(&world).map_err(|e| e.into_error(Some(source)))?;
        let mut world = world;
        world.motors = motor_worlds(source, &world)?;
        Ok(world)
    }

    /// The world of motor `motor`: its `[motors.N]` table merged over the top level, or the top level.
    pub fn of_motor(&self, motor: usize) -> World {
        self.motors.iter().find(|(m, _)| *m == motor).map_or_else(
            || World { motors: Vec::new(), motor_tables: Default::default(), ..self.clone() },
            |(_, w)| w.clone(),
        )
    }

    /// Reads, parses and checks a world file.
    pub fn load(path: impl AsRef<Path>) -> Result<World, WorldError> {
        let path = path.as_ref();
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| WorldError {
            file: Some(name.clone()),
            key: None,
            line: None,
            message: format!("cannot read: {e}"),
        })?;
        World::from_toml_str(&text).map_err(|e| WorldError { file: Some(name), ..e })
    }

    /// Checks what the types alone do not: ranges, units that fit the axis, ordering ([`World::from_toml_str`]
    /// and [`World::load`] already did; this is for worlds built or changed in code).
    pub fn check(&self) -> Result<(), WorldError> {
        crate::board::Plan::compile(self).map(|_| ()).map_err(|e| e.into_error(None))
    }
}

/// Each `[motors.N]` table merged over the file's top level (tables key by key, any other value or array
/// replaced) and checked as a world of its own. Errors name the key under `motors.N`; the line is that of
/// the `[motors.N…]` header or key where it can be found.
fn motor_worlds(source: &str, world: &World) -> Result<Vec<(usize, World)>, WorldError> {
    if world.motor_tables.is_empty() {
        return Ok(Vec::new());
    }
    let mut base: toml::Table = toml::from_str(source).map_err(|e| WorldError {
        file: None,
        key: None,
        line: None,
        message: e.message().trim().to_string(),
    })?;
    base.remove("motors");
    let mut out = Vec::new();
    for (name, table) in &world.motor_tables {
        let line = source
            .find(&format!("[motors.{name}"))
            .or_else(|| source.find(&format!("motors.{name}")))
            .map(|o| line_of(source, o));
        let error = |key: Option<String>, message: String| WorldError {
            file: None,
            key: Some(key.map_or(format!("motors.{name}"), |k| format!("motors.{name}.{k}"))),
            line,
            message,
        };
        let motor: usize =
            name.parse().ok().filter(|m| *m < 8).ok_or_else(|| error(None, "a motor number 0…7 is expected".into()))?;
        if table.contains_key("inputs") {
            return Err(error(
                Some("inputs".into()),
                "the inputs are the module's: give them at the top level, not per motor".into(),
            ));
        }
        let mut merged = base.clone();
        merge(&mut merged, table);
        // Written out and read again: the world's values keep their places in a text (`Spanned`).
        let text = toml::to_string(&merged).map_err(|e| error(None, e.to_string()))?;
        let own: World = toml::from_str(&text).map_err(|e| {
            let key = e.span().and_then(|s| key_at(&text, s.start));
            error(key, e.message().trim().to_string())
        })?;
        crate::board::Plan::compile(&own).map_err(|e| {
            let e = e.into_error(None);
            error(e.key, e.message)
        })?;
        out.push((motor, own));
    }
    Ok(out)
}

/// Merges `over` into `base`: a table into a table key by key, anything else replaced.
fn merge(base: &mut toml::Table, over: &toml::Table) {
    for (key, value) in over {
        match (base.get_mut(key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            _ => {
                base.insert(key.clone(), value.clone());
            }
        }
    }
}

/// The dotted key path at byte `offset` of a TOML document: a `[table]` header's path, or the enclosing
/// header's path plus the key the offset points at (an unknown key) or whose value it points at, with the
/// outer key of an inline table (`bounce = { time = … }` → `bounce.time`).
fn key_at(source: &str, offset: usize) -> Option<String> {
    let offset = offset.min(source.len());
    let line_start = source[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line_end = source[offset..].find('\n').map_or(source.len(), |i| offset + i);
    let header = |l: &str| l.trim().trim_matches(|c| c == '[' || c == ']').trim().to_string();
    let line = &source[line_start..line_end];
    if line.trim_start().starts_with('[') {
        return Some(header(line));
    }
    let table = source[..line_start].lines().rev().find(|l| l.trim_start().starts_with('[')).map(header);
    let is_key_char = |c: char| c.is_alphanumeric() || c == '_' || c == '-';
    let before = &source[line_start..offset];
    let word: String = source[offset..line_end].chars().take_while(|c| is_key_char(*c)).collect();
    let after_word = source[offset + word.len()..line_end].trim_start();
    // The key named at the offset itself, or the last `key =` before it.
    let (mut key, key_start) = if !word.is_empty() && after_word.starts_with('=') {
        (word, before.len())
    } else {
        let eq = before.rfind('=')?;
        let start = before[..eq].rfind(['{', ',']).map_or(0, |i| i + 1);
        (before[start..eq].trim().to_string(), start)
    };
    // Inside an inline table: prefix the key the table is the value of.
    let prefix = &before[..key_start];
    if let Some(brace) = prefix.rfind('{') {
        if !prefix[brace..].contains('}') {
            if let Some(eq) = prefix[..brace].rfind('=') {
                let start = prefix[..eq].rfind(['{', ',']).map_or(0, |i| i + 1);
                key = format!("{}.{key}", prefix[start..eq].trim());
            }
        }
    }
    match table {
        Some(t) if !t.is_empty() => Some(format!("{t}.{key}")),
        _ => Some(key),
    }
}
