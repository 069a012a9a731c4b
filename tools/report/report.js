// report.html's tables and histograms (plain DOM and 2-D canvas, no library):
// every counter of stats.json, the evaluation against objects.yaml when there is
// one, the frame-time and end-to-end latency histograms. Inlined by the report
// writer (tools/report/report.cpp).
(function () {
  "use strict";
  const data = JSON.parse(document.getElementById("zonemap-data").textContent);

  function element(tag, text, attributes) {
    const e = document.createElement(tag);
    if (text !== undefined) e.textContent = text;
    for (const [k, v] of Object.entries(attributes || {})) e.setAttribute(k, v);
    return e;
  }

  // Nested objects flattened to dotted names: "frame_ms.p50".
  function flatten(value, prefix, out) {
    if (value !== null && typeof value === "object" && !Array.isArray(value)) {
      for (const [k, v] of Object.entries(value)) flatten(v, prefix ? prefix + "." + k : k, out);
    } else {
      out.push([prefix, Array.isArray(value) ? JSON.stringify(value) : String(value)]);
    }
    return out;
  }

  function table(rows, header) {
    const t = element("table");
    if (header) {
      const tr = element("tr");
      for (const h of header) tr.appendChild(element("th", h));
      t.appendChild(tr);
    }
    for (const row of rows) {
      const tr = element("tr");
      for (const cell of row) tr.appendChild(element("td", cell));
      t.appendChild(tr);
    }
    return t;
  }

  // A histogram of (upper edge ms, count) bins on a log axis.
  function histogram(canvas, bins, label) {
    const ctx = canvas.getContext("2d");
    const w = canvas.width;
    const h = canvas.height;
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, 0, w, h);
    const used = bins.filter((b) => b[1] > 0);
    if (used.length === 0) {
      ctx.fillStyle = "#666";
      ctx.fillText("no samples", 10, 20);
      return;
    }
    const lo = Math.log10(used[0][0]) - 0.1;
    const hi = Math.log10(used[used.length - 1][0]) + 0.1;
    const top = Math.max(...used.map((b) => b[1]));
    const x = (ms) => 40 + ((Math.log10(ms) - lo) / (hi - lo)) * (w - 60);
    ctx.fillStyle = "#3a7bd5";
    let previous = used[0][0] / Math.pow(10, 0.05);
    for (const [edge, count] of bins) {
      if (count > 0) {
        const bar = (count / top) * (h - 40);
        ctx.fillRect(x(previous), h - 20 - bar, Math.max(1, x(edge) - x(previous) - 1), bar);
      }
      previous = edge;
    }
    ctx.fillStyle = "#000";
    ctx.font = "11px sans-serif";
    for (let d = Math.ceil(lo); d <= Math.floor(hi); ++d) {
      ctx.fillText(Math.pow(10, d) + " ms", x(Math.pow(10, d)) - 10, h - 5);
    }
    ctx.fillText(label + " (peak " + top + ")", 45, 14);
  }

  // Samples into 20 log bins per decade, like the pipeline's LatencyHistogram.
  function binned(samples) {
    const counts = new Map();
    for (const ms of samples) {
      const b = Math.floor(Math.log10(Math.max(ms, 1e-3) / 1e-3) * 20) + 1;
      counts.set(b, (counts.get(b) || 0) + 1);
    }
    return [...counts.keys()].sort((a, b) => a - b).map((b) => [1e-3 * Math.pow(10, b / 20), counts.get(b)]);
  }

  const stats = document.getElementById("stats");
  stats.appendChild(table(flatten(data.stats, "", []), ["counter", "value"]));

  const evaluation = document.getElementById("evaluation");
  if (data.evaluation) {
    const e = data.evaluation;
    const summary = Object.entries(e).filter(([, v]) => typeof v !== "object");
    evaluation.appendChild(table(summary.map(([k, v]) => [k, String(v)]), ["measure", "value"]));
    if (Array.isArray(e.objects) && e.objects.length) {
      const keys = Object.keys(e.objects[0]);
      evaluation.appendChild(table(e.objects.map((o) => keys.map((k) => JSON.stringify(o[k]))), keys));
    }
  } else {
    evaluation.appendChild(element("p", "No objects.yaml with this sequence: nothing to evaluate against."));
  }

  histogram(document.getElementById("frame-times"), binned(data.frame_ms), "mapping time per frame");
  const latency = document.getElementById("latency");
  if (data.end_to_end_bins.length) {
    histogram(latency, data.end_to_end_bins, "end to end, frame acquired to boxes out");
  } else {
    latency.replaceWith(element("p", "End-to-end latency: threaded runs only (--pipeline)."));
  }
  document.body.dataset.tablesReady = "1";
})();
