//! The page: HTML, its style and drawing code inline, the data as JSON in a script element.

use crate::figures::Content;
use crate::runs::RunFolder;

const STYLE: &str = include_str!("report.css");
const SCRIPT: &str = include_str!("report.js");

/// Text for HTML element content (`&`, `<`, `>` escaped).
fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// The page of `folder` drawing `content`.
pub fn html(folder: &RunFolder, content: &Content) -> String {
    // JSON inside <script>: "</" would end the element; "<\/" is the same JSON string.
    let data = serde_json::to_string(content).expect("the report's data serialises").replace("</", "<\\/");
    let kind = if folder.comparison.is_some() { "comparison" } else { "run" };
    let runs: Vec<&str> = folder.runs.iter().map(|r| r.label.as_str()).collect();
    format!(
        r#"<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="generator" content="lash {version}">
<title>lash report: {name}</title>
<style>
{STYLE}</style>
</head>
<body>
<h1>lash report: {name} ({kind}: {runs})</h1>
<p class="desc">{description}</p>
<table id="summary"></table>
<p id="speedup" class="hint"></p>
<ul id="notes" class="notes"></ul>
<h2>Mechanism</h2>
<canvas id="mechanism" width="1000" height="380"></canvas>
<div class="controls" id="mechanism-controls"><button id="play">Play</button><input type="range" id="frame" min="0" max="0" value="0"><span id="frame-time"></span></div>
<h2>Clearance joints: the journal's orbit inside its clearance circle</h2>
<div class="orbits" id="orbits"></div>
<h2>Channels</h2>
<label>channel <select id="channel"></select></label> <span class="hint">drag across a plot to zoom in time, frequency or angle; double-click to reset</span>
<canvas id="over-time" width="1000" height="300"></canvas>
<canvas id="over-angle" width="1000" height="300"></canvas>
<canvas id="spectrum" width="1000" height="300"></canvas>
<p class="hint">Spectra: one-sided amplitude, Hann window, mean removed, over the whole run as sampled; each point is the largest of a group of bins. Time plots keep each group's smallest and largest sample, so no impact peak is lost.</p>
<script type="application/json" id="data">{data}</script>
<script>
{SCRIPT}</script>
</body>
</html>
"#,
        version = env!("CARGO_PKG_VERSION"),
        name = escape(&content.scenario),
        description = escape(&content.description),
        runs = escape(&runs.join(", ")),
    )
}
