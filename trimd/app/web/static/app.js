// trimd serve's page: polls the JSON API (relative URLs: BlueOS may serve it under a
// path) and draws the dive's segments as inline SVG. No library, no network beyond trimd.
"use strict";
const PANELS = [["W − B [N]", "net_force_N", "net_force_std_N", null],
                ["W·x_g − B·x_b [N·m]", "net_moment_Nm", "net_moment_std_Nm", 0],
                ["W·y_g − B·y_b [N·m]", "net_moment_Nm", "net_moment_std_Nm", 1]];
const SVG = "http://www.w3.org/2000/svg";

async function get(path) {
  const r = await fetch(path, {cache: "no-store"});
  if (!r.ok) throw new Error(`${path}: HTTP ${r.status}`);
  return r.json();
}

function el(parent, tag, attrs, text) {
  const e = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  parent.appendChild(e);
  return e;
}

function pick(seg, key, k) { const v = seg[key]; return k === null ? v : (v ? v[k] : null); }

// One panel: segments (value ± std over [t_start_s, t_end_s]), baseline band, alert lines.
function panel(title, segs, alerts, base, get) {
  const W = 600, H = 140, L = 60, R = 10, T = 16, B = 18;
  const svg = document.createElementNS(SVG, "svg");
  svg.setAttribute("viewBox", `0 0 ${W} ${H}`);
  svg.setAttribute("data-title", title);
  el(svg, "text", {x: L, y: 12}, title);
  const pts = segs.map(s => [s.t_start_s, s.t_end_s, get(s, 0), get(s, 1), s.baseline])
                  .filter(p => p[2] !== null && p[2] !== undefined);
  if (!pts.length) { el(svg, "text", {x: L, y: H / 2}, "no steady segment yet"); return svg; }
  let t0 = Math.min(...pts.map(p => p[0])), t1 = Math.max(...pts.map(p => p[1]));
  let lo = Math.min(...pts.map(p => p[2] - (p[3] || 0))), hi = Math.max(...pts.map(p => p[2] + (p[3] || 0)));
  if (base) { lo = Math.min(lo, base[0] - base[1]); hi = Math.max(hi, base[0] + base[1]); }
  for (const a of alerts) t1 = Math.max(t1, a.t_s);
  if (hi - lo < 1e-6) { lo -= 1; hi += 1; }
  const pad = 0.1 * (hi - lo); lo -= pad; hi += pad;
  const x = t => L + (W - L - R) * (t - t0) / Math.max(t1 - t0, 1);
  const y = v => T + (H - T - B) * (hi - v) / (hi - lo);
  el(svg, "text", {x: 2, y: y(hi) + 10}, hi.toFixed(2));
  el(svg, "text", {x: 2, y: y(lo)}, lo.toFixed(2));
  el(svg, "text", {x: L, y: H - 4}, `${t0.toFixed(0)} s`);
  el(svg, "text", {x: W - R - 50, y: H - 4}, `${t1.toFixed(0)} s`);
  if (base) {
    el(svg, "rect", {class: "band", x: L, width: W - L - R, y: y(base[0] + base[1]),
                     height: Math.max(1, y(base[0] - base[1]) - y(base[0] + base[1]))});
    el(svg, "line", {class: "base", x1: L, x2: W - R, y1: y(base[0]), y2: y(base[0])});
  }
  for (const [a, b, v, sd, isBase] of pts) {
    const cls = isBase ? "seg baseline" : "seg";
    el(svg, "line", {class: cls, x1: x(a), x2: x(b), y1: y(v), y2: y(v)});
    el(svg, "line", {class: cls, x1: x((a + b) / 2), x2: x((a + b) / 2),
                     y1: y(v - (sd || 0)), y2: y(v + (sd || 0))});
    el(svg, "circle", {class: cls, cx: x((a + b) / 2), cy: y(v), r: 3});
  }
  for (const a of alerts) el(svg, "line", {class: "alertline", x1: x(a.t_s), x2: x(a.t_s), y1: T, y2: H - B});
  return svg;
}

function drawDive(d) {
  document.getElementById("dive").textContent = d.dive ? `${d.dive}${d.running ? " (running)" : ""}` : "none yet";
  const plots = document.getElementById("plots");
  plots.replaceChildren(...PANELS.map(([title, key, sdKey, k], i) => {
    const base = d.baseline && d.baseline.q[i] !== null ? [d.baseline.q[i], d.baseline.std[i]] : null;
    const get = (s, which) => pick(s, which ? sdKey : key, k);
    return panel(title, d.segments, d.alerts.filter(a => a.component === i), base, get);
  }));
}

function listItems(id, items, cls, empty) {
  const ul = document.getElementById(id);
  if (!items.length) { ul.innerHTML = `<li class="quiet">${empty}</li>`; return; }
  ul.replaceChildren(...items.map(t => { const li = document.createElement("li"); li.className = cls; li.textContent = t; return li; }));
}

function drawHistory(h) {
  const rows = [];
  for (const v of h.vehicles) {
    for (const t of v.trims) rows.push([t.t_unix, t.time_utc, `${v.vehicle}: trim, W − B ${t.estimate.net_force_N.toFixed(2)} N` +
      (t.proposal ? `, ballast ${t.proposal.feasible ? "proposed" : "NOT feasible"}` : "")]);
    for (const a of v.alerts) rows.push([a.t_unix, a.time_utc, `${v.vehicle}: ALERT ${a.text}`]);
    for (const r of v.verifications) rows.push([r.t_unix, r.time_utc, `${v.vehicle}: verify: ${r.message}`]);
    for (const r of v.installed) rows.push([r.t_unix, r.time_utc, `${v.vehicle}: ballast recorded (${r.source})`]);
  }
  rows.sort((a, b) => b[0] - a[0]);
  document.querySelector("#history tbody").replaceChildren(...rows.slice(0, 50).map(([, when, what]) => {
    const tr = document.createElement("tr");
    for (const text of [when, what]) { const td = document.createElement("td"); td.textContent = text; tr.appendChild(td); }
    return tr;
  }));
}

function drawTrim(r) {
  let text = `${r.time_utc} (${r.profile})\n\n${r.estimate_text}`;
  const p = r.proposal;
  if (p) {
    text += `\n\nproposal (${p.method}): ${p.feasible ? "feasible" : "NOT feasible"}\n`;
    text += (p.changes || []).map(c => `  ${c.text}`).join("\n");
  }
  const v = r.verifications.at(-1);
  text += `\n\nverdict: ${v ? v.message : "no verify hold since this trim"}`;
  document.getElementById("trim").textContent = text;
}

// The history and the last trim change rarely: read every HISTORY_EVERY-th refresh.
const HISTORY_EVERY = 5;
let refreshes = 0;

async function refresh() {
  const st = document.getElementById("status");
  try {
    const s = await get("api/status");
    st.textContent = s.connected ? `${s.vehicle}: ${s.mode}, ${s.armed ? "armed (dive " + (s.dive ? s.dive.id : "?") + ")" : "disarmed"}`
                                 : `${s.vehicle}: no vehicle${s.link_error ? " (" + s.link_error + ")" : ""}`;
    st.className = s.connected ? "status ok" : "status bad";
    const [a, d] = await Promise.all([get("api/alerts"), get("api/segments")]);
    listItems("alerts", a.alerts.slice().reverse().map(x => `${x.time_utc}: ${x.text}`), "alert", "none");
    drawDive(d);
    if (refreshes++ % HISTORY_EVERY === 0) {
      const h = await get("api/history");
      drawHistory(h);
      const mine = h.vehicles.find(v => v.vehicle === s.vehicle);
      if (mine && mine.trims.length) drawTrim(await get("api/trims/-1/report"));
    }
  } catch (e) {
    st.textContent = `trimd not answering: ${e.message}`;
    st.className = "status bad";
  }
}

refresh();
setInterval(refresh, 2000);
