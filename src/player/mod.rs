//! The 3D player of the HTML reports: the scene's supports and barriers, the object mesh and
//! the hand's collision shapes of a trajectory, the output and the original it was warped
//! from overlaid or side by side, with play/pause, a time slider, orbit and zoom, the
//! waypoints and the pushed-out object path, the correspondences as short segments, the
//! frames whose hand-object penetration is above the physics limit in red, and the τ strip
//! under the slider (which output frames have a source frame).
//!
//! Everything geometric is computed here ([`data`]: forward kinematics per frame, meshes,
//! scene) and written next to the page as one script per trajectory, loaded when the user
//! picks it (lazy, one at a time); the page's own script (`player.js`, ours, canvas 2D with
//! its own perspective projection and painter's sort) only draws. No network: the page
//! works from disk.
//!
//! Test hooks: the URL fragment `#play=<id>&frame=<n>` opens a trajectory at a frame;
//! after each drawing the page sets `data-player-frame`, `data-player-ink` (pixels that are
//! not background), `data-player-shown-ms` (navigation to the first picture) and, on errors, `data-player-errors` on `<body>`; `&selftest=1` moves the
//! slider and records in `data-player-selftest` whether time and the picture changed;
//! `&only=1` hides the rest of the page (screenshots).

pub mod data;
mod encode;

use std::path::Path;

use crate::model::json::write_atomic;
use crate::{Error, Result};

/// The player's script (written by us; no library).
pub const SCRIPT: &str = include_str!("player.js");

/// One trajectory a page offers.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// Identifier in the page (and in `#play=`).
    pub id: String,
    /// What the picker shows.
    pub label: String,
    /// The data script, relative to the page.
    pub src: String,
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The player's HTML (controls, canvas, τ strip) and script for `entries`; empty when there
/// is nothing to play.
pub fn section(entries: &[Entry]) -> String {
    if entries.is_empty() {
        return String::new();
    }
    let list: Vec<serde_json::Value> = entries
        .iter()
        .map(|e| serde_json::json!({"id": e.id, "label": e.label, "src": e.src}))
        .collect();
    // `</` inside a script element would end it.
    let list = serde_json::to_string(&list)
        .unwrap_or_else(|_| "[]".into())
        .replace("</", "<\\/");
    let options: String = entries
        .iter()
        .map(|e| {
            format!(
                "<option value=\"{}\">{}</option>",
                escape(&e.id),
                escape(&e.label)
            )
        })
        .collect();
    format!(
        r#"<section id="player" class="player">
<h2>Player</h2>
<div class="pl-bar">
<select id="pl-pick" title="trajectory">{options}</select>
<button id="pl-play" type="button">Play</button>
<select id="pl-mode" title="view"><option value="overlay">original overlaid</option><option value="side">side by side</option><option value="output">output only</option></select>
<label><input id="pl-contacts" type="checkbox" checked> correspondences</label>
<label><input id="pl-paths" type="checkbox" checked> paths</label>
<span id="pl-status" class="pl-status">pick a trajectory</span>
</div>
<canvas id="pl-canvas" width="960" height="540" title="drag: orbit, wheel: zoom, shift-drag: pan"></canvas>
<input id="pl-slider" type="range" min="0" max="0" value="0" step="1" aria-label="output frame">
<canvas id="pl-strip" width="960" height="30" title="τ: output frames with a source frame (dark), penetration above the limit (red)"></canvas>
<p id="pl-frame" class="pl-frame"></p>
<p class="note">Output in colour, original (at the source frame t* of each output frame) in grey; correspondences green (hand point to object point); object path blue (output, after push-out) and grey (original); waypoints as orange rings; hand in red on frames whose hand-object penetration is above the physics limit. Drag to orbit, wheel to zoom, shift-drag to pan, space to play.</p>
</section>
<script>
const dexwarpPlayerEntries = {list};
{script}
</script>
"#,
        script = SCRIPT
    )
}

/// The player's CSS.
pub const STYLE: &str = ".player canvas { display: block; width: 100%; max-width: 960px; background: #f4f6f8; border: 1px solid #ccc; }\n.player #pl-strip { background: #fff; border-top: none; }\n.player input[type=range] { width: 100%; max-width: 960px; display: block; margin: 4px 0 0; }\n.pl-bar { display: flex; gap: 0.6em; align-items: center; flex-wrap: wrap; margin-bottom: 0.4em; }\nbody.pl-only > *:not(#player) { display: none; }\nbody.pl-only { margin: 0.5em; }\n.pl-status, .pl-frame { color: #444; font-size: 0.9em; }\n";

/// The entries whose data script was written, and the others with the reason.
pub type Written = (Vec<Entry>, Vec<(Entry, String)>);

/// Writes the data script of every built entry of `items` into `dir` (created), and
/// removes older `<prefix>*.js` files there that are not rewritten. Returns the entries
/// written and, for the rest, why not.
pub fn write_scripts(
    dir: &Path,
    prefix: &str,
    items: Vec<(Entry, Result<serde_json::Value>)>,
) -> Result<Written> {
    std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
    let (mut ok, mut missing) = (Vec::new(), Vec::new());
    let mut written = std::collections::HashSet::new();
    for (entry, value) in items {
        match value {
            Ok(v) => {
                let name = Path::new(&entry.src)
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default();
                write_atomic(&dir.join(&name), data::script(&entry.id, &v).as_bytes())?;
                written.insert(name);
                ok.push(entry);
            }
            Err(e) => missing.push((entry, e.to_string())),
        }
    }
    if let Ok(rd) = std::fs::read_dir(dir) {
        for e in rd.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with(prefix) && name.ends_with(".js") && !written.contains(&name) {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
    Ok((ok, missing))
}
