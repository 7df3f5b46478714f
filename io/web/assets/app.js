// hvac-twin dashboard: the site overview (#/) and the unit view (#/unit/<site>/<unit>). State
// comes from the JSON API, updates from the server's event stream (/events); the records in the
// stream are hvac-twin-echo's JSON. No library; charts are chart.js's own SVG.
"use strict";

(() => {
  const $ = (id) => document.getElementById(id);
  const WINDOWS = [900, 3600, 21600, 86400];
  const KEY_SENSORS = ["cooling_capacity", "condenser_heat_flow", "evaporator_heat_flow",
    "compressor_power", "cop", "superheat", "subcooling", "zone_air_temperature",
    "envelope_heat_loss", "internal_gains"];
  const HOLD_TEXT = {
    WARM_UP: "held: warming up after a cold start",
    COMPRESSOR_OFF: "held: compressor off",
    START_UP: "held: compressor just started",
    CYCLING: "held: compressor cycling",
    DEGRADED: "held: estimates degraded",
  };
  const STALE_TEXT = {
    LIVELINESS_LOST: "publisher lost (DDS liveliness)",
    DEADLINE_MISSED: "no update within its deadline",
    NO_PUBLISHER: "no live publisher on DDS",
  };
  const STATE_ICON = { NORMAL: "✓", SUSPECT: "⚠", LEAK: "✖", NONE: "–" };
  const VERDICT_TEXT = {
    IN_BAND: "σ consistent",
    HIGH: "σ too small: model error or a sensor fault",
    LOW: "σ too large (conservative)",
    INSUFFICIENT_DATA: "σ check: not enough data yet",
  };
  const COLORS = ["#1f5fbf", "#b5510b", "#2e7d32", "#7b1fa2"];

  const state = {
    source: null,
    view: null,
    units: new Map(),       // overview: key -> {summary, received, li}
    site: null, unit: null, // unit view
    data: null,             // /api/unit
    series: new Map(),      // key -> {unit, resolution, points}
    charts: new Map(),      // chart id -> chart
    windowS: 3600,
    clockOffset: 0,         // server's CLOCK_REALTIME - the browser's [ms]
    renderTimer: 0,
    historyTimer: 0,
    server: null,
  };

  // --- Formatting ----------------------------------------------------------------------------

  function decimalsFor(sigma) {
    if (!(sigma > 0) || !isFinite(sigma)) return 2;
    return Math.max(0, Math.min(6, -Math.floor(Math.log10(sigma))));
  }
  // Pa reads better as kPa; everything else as published.
  function scaleOf(unit) {
    return unit === "Pa" ? { k: 1e-3, unit: "kPa" } : { k: 1, unit: unit || "" };
  }
  function withUnit(text, unit) {
    return unit && unit !== "1" ? `${text} ${unit}` : text;
  }
  // "5075 ± 514 W": value ± 2σ, decimals following σ.
  function valueText(v, sigma, unit) {
    const sc = scaleOf(unit);
    const value = v * sc.k;
    if (!(sigma > 0)) return withUnit(value.toFixed(2), sc.unit);
    const s2 = 2 * sigma * sc.k;
    const d = decimalsFor(s2);
    return withUnit(`${value.toFixed(d)} ± ${s2.toFixed(d)}`, sc.unit);
  }
  function num(v, d) {
    return typeof v === "number" && isFinite(v) ? v.toFixed(d) : "–";
  }
  function ago(ms) {
    if (!(ms >= 0)) return "";
    const s = Math.round(ms / 1000);
    if (s < 60) return `${s} s ago`;
    if (s < 3600) return `${Math.round(s / 60)} min ago`;
    return `${(s / 3600).toFixed(1)} h ago`;
  }
  function nsToMs(ns) {
    return Math.floor(ns / 1e6);
  }
  function text(tag, content, cls) {
    const e = document.createElement(tag);
    if (content !== undefined) e.textContent = content;
    if (cls) e.className = cls;
    return e;
  }
  function unitHash(site, unit) {
    return `#/unit/${encodeURIComponent(site)}/${encodeURIComponent(unit)}`;
  }
  // " · LEAK since 12:03:40" while an episode lasts.
  function sinceText(l) {
    if (l.leak_since_ns > 0) return ` · LEAK since ${HvacChart.clock(nsToMs(l.leak_since_ns), true)}`;
    if (l.suspect_since_ns > 0) return ` · SUSPECT since ${HvacChart.clock(nsToMs(l.suspect_since_ns), true)}`;
    return "";
  }
  function leakState(summary) {
    return summary.leak ? summary.leak.state : "NONE";
  }
  function estimateText(s) {
    if (!s.quality) return "no estimate yet";
    let t = s.quality;
    const flags = (s.flag_names || []).map((f) => f.replace(/_/g, " "));
    if (flags.length) t += ` (${flags.join(", ")})`;
    if (s.consistency) t += ` · ${VERDICT_TEXT[s.consistency.verdict] || s.consistency.verdict}`;
    return t;
  }

  // --- Server access ---------------------------------------------------------------------------

  function setConn(live, message) {
    const c = $("conn");
    c.textContent = message;
    c.className = "conn " + (live ? "live" : "down");
  }

  function getJson(url) {
    return fetch(url, { cache: "no-store", credentials: "same-origin" }).then((r) => {
      if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
      return r.json();
    });
  }

  // One event stream at a time; `onHello` runs on every (re)connection, after which the page
  // fetches the state it shows: nothing published in between is missed.
  function stream(url, handlers) {
    if (state.source) state.source.close();
    const source = new EventSource(url);
    state.source = source;
    source.addEventListener("hello", () => {
      setConn(true, "live");
      handlers.hello();
    });
    source.addEventListener("resync", () => handlers.hello());
    for (const [name, fn] of Object.entries(handlers))
      if (name !== "hello") source.addEventListener(name, (e) => fn(JSON.parse(e.data)));
    source.onerror = () => setConn(false, "reconnecting…");
  }

  // --- Overview ---------------------------------------------------------------------------------

  function showOverview() {
    state.view = "overview";
    state.site = state.unit = null;
    clearTimeout(state.historyTimer);
    $("overview-view").hidden = false;
    $("unit-view").hidden = true;
    $("crumb").textContent = "";
    document.title = "hvac-twin dashboard";
    state.units.clear();
    $("tiles").replaceChildren();
    stream("/events", {
      hello: () =>
        getJson("/api/overview")
          .then((o) => {
            state.server = o.server;
            for (const s of o.units) updateSummary(s);
            footer();
          })
          .catch((e) => setConn(false, e.message)),
      summary: updateSummary,
    });
  }

  function updateSummary(s) {
    const key = JSON.stringify([s.site, s.unit]);
    const old = state.units.get(key);
    state.units.set(key, { summary: s, received: Date.now(), li: old ? old.li : null });
    if (state.view === "overview") renderTile(key);
    if (state.view === "unit" && s.site === state.site && s.unit === state.unit) {
      if (state.data) state.data.summary = s;
      unitStatus();
    }
  }

  function renderTile(key) {
    const entry = state.units.get(key);
    const s = entry.summary;
    let li = entry.li;
    if (!li) {
      li = document.createElement("li");
      entry.li = li;
      li.className = "tile";
      li.dataset.key = key;
      li.innerHTML =
        '<a><div class="tile-head"><span class="tile-name"></span><span class="muted tile-site"></span></div>' +
        '<div class="state"></div><p class="held"></p><dl class="facts"></dl>' +
        '<div class="stale-note" role="status"></div></a>';
      const tiles = $("tiles");
      const after = [...tiles.children].find((c) => c.dataset.key > key);
      tiles.insertBefore(li, after || null);
    }
    $("overview-empty").hidden = true;
    const leak = leakState(s);
    const stale = s.stale !== "NO";
    li.dataset.unit = s.unit;
    li.dataset.site = s.site;
    li.dataset.leakState = leak;
    li.dataset.stale = s.stale;
    li.dataset.cycle = s.health ? s.health.cycle : "";
    // When the cycle was published (its stamp, the tick, plus the cycle's own time: the health
    // sample is written at the cycle's end) and when the page showed it: the browser test's
    // latency figure.
    li.dataset.stampMs = s.health ? nsToMs(s.health.timestamp_ns) : "";
    li.dataset.publishedMs = s.health ? nsToMs(s.health.timestamp_ns) + s.health.cycle_time_ms : "";
    li.dataset.shownMs = Date.now();
    li.classList.toggle("leak", leak === "LEAK");
    li.classList.toggle("suspect", leak === "SUSPECT");
    li.classList.toggle("stale", stale);
    const a = li.querySelector("a");
    a.href = unitHash(s.site, s.unit);
    li.querySelector(".tile-name").textContent = s.unit;
    li.querySelector(".tile-site").textContent = s.site;
    const badge = li.querySelector(".state");
    badge.className = `state state-${leak}`;
    badge.textContent = leak === "NONE" ? "– no leak model" : `${STATE_ICON[leak]} ${leak}`;
    const held = s.leak && s.leak.hold !== "NONE" ? HOLD_TEXT[s.leak.hold] || `held: ${s.leak.hold}` : "";
    li.querySelector(".held").textContent = held;
    const facts = li.querySelector(".facts");
    facts.replaceChildren();
    const fact = (dt, dd, cls) => {
      facts.append(text("dt", dt));
      const d = text("dd", dd, cls);
      facts.append(d);
      return d;
    };
    fact("Estimate", estimateText(s));
    if (s.health) {
      fact("Modbus", s.health.modbus_connected ? "connected"
        : `DOWN${s.health.modbus_last_error ? ": " + s.health.modbus_last_error : ""}`);
      fact("Last cycle", "", "last-cycle");
    }
    if (s.leak) {
      const ref = s.leak.charge_reference > 0 ? `, commissioned ${s.leak.charge_reference.toFixed(3)}` : "";
      fact("Charge", `${valueText(s.leak.charge, s.leak.charge_sigma, "kg")} (nameplate ${s.leak.nameplate_charge.toFixed(3)}${ref})`);
      fact("Leak test", `${num(s.leak.cusum, 1)} of ${num(s.leak.threshold, 1)}${sinceText(s.leak)}`);
    }
    ageTile(li);
    const note = li.querySelector(".stale-note");
    note.dataset.staleReason = s.stale;
    a.setAttribute("aria-label", `${s.unit} (${s.site}): ${leak === "NONE" ? "no leak model" : leak}` +
      `${held ? ", " + held : ""}${stale ? ", STALE: " + (STALE_TEXT[s.stale] || s.stale) : ""}`);
  }

  // The parts of a tile that change with time: ages.
  function ageTile(li) {
    const entry = state.units.get(li.dataset.key);
    if (!entry) return;
    const s = entry.summary;
    const age = s.age_ms + (Date.now() - entry.received);
    const last = li.querySelector(".last-cycle");
    if (last && s.health) {
      last.textContent = `#${s.health.cycle} at ${HvacChart.clock(nsToMs(s.health.timestamp_ns), true)}` +
        ` (${ago(age)}), ${num(s.health.cycle_time_ms, 1)} ms`;
    }
    const note = li.querySelector(".stale-note");
    note.textContent = s.stale === "NO" ? "" : `STALE: ${STALE_TEXT[s.stale] || s.stale}; last data ${ago(age)}`;
  }

  function footer() {
    const s = state.server;
    if (!s) return;
    $("footer").textContent = `${state.units.size || ""}${state.units.size ? " unit(s) · " : ""}` +
      `history per series: ${s.fine_capacity} samples at full resolution, then ${s.minute_capacity} ` +
      `one-minute buckets · ${s.clients} event stream(s) open · read-only`;
  }

  // --- Unit view --------------------------------------------------------------------------------

  function showUnit(site, unit) {
    state.view = "unit";
    state.site = site;
    state.unit = unit;
    state.data = null;
    state.series = new Map();
    state.charts = new Map();
    for (const id of ["leak-charts", "key-charts", "other-charts", "point-charts", "health-charts"])
      $(id).replaceChildren();
    $("points").tBodies[0].replaceChildren();
    $("health").replaceChildren();
    $("unit-status").replaceChildren();
    $("overview-view").hidden = true;
    $("unit-view").hidden = false;
    $("unit-title").textContent = `${unit}`;
    const crumb = $("crumb");
    crumb.replaceChildren();
    const back = text("a", "Overview");
    back.href = "#/";
    crumb.append(back, text("span", ` › ${site} › ${unit}`));
    windowButtons();
    const q = `site=${encodeURIComponent(site)}&unit=${encodeURIComponent(unit)}`;
    stream(`/events?${q}`, {
      hello: () => loadUnit(),
      summary: updateSummary,
      record: applyRecord,
    });
  }

  function query() {
    return `site=${encodeURIComponent(state.site)}&unit=${encodeURIComponent(state.unit)}`;
  }

  function loadUnit() {
    const site = state.site, unit = state.unit;
    getJson(`/api/unit?${query()}`)
      .then((d) => {
        if (state.site !== site || state.unit !== unit) return;
        $("unit-missing").hidden = true;
        state.data = {
          summary: d.summary, health: d.health, leak: d.leak,
          sensors: new Map(d.sensors.map((r) => [r.name, r])),
          observations: new Map(d.observations.map((r) => [r.point, r])),
          consistency: new Map(d.consistency.map((r) => [r.point, r])),
        };
        unitStatus();
        return loadHistory();
      })
      .catch(() => {
        $("unit-missing").hidden = false;
      });
  }

  function loadHistory() {
    clearTimeout(state.historyTimer);
    const site = state.site, unit = state.unit, windowS = state.windowS;
    return getJson(`/api/history?${query()}&window=${windowS}&points=300`).then((h) => {
      if (state.site !== site || state.unit !== unit || state.windowS !== windowS) return;
      state.clockOffset = h.now_ms - Date.now();
      const series = new Map();
      let coarse = false;
      for (const [key, s] of Object.entries(h.series)) {
        const points = s.t.map((t, i) => ({ t, v: s.v[i], s: s.s[i], lo: s.lo[i], hi: s.hi[i] }));
        series.set(key, { unit: s.unit, resolution: s.resolution, points });
        coarse = coarse || s.resolution === "minute";
      }
      state.series = series;
      $("resolution").textContent = coarse
        ? "older than the server keeps every sample: one-minute buckets (line = mean, band = " +
          "min(v − 2σ) to max(v + 2σ)); recent: every sample, band = ± 2σ"
        : "every sample: line = value, band = ± 2σ";
      // New samples are appended live; the buckets are fetched again each minute.
      if (coarse) state.historyTimer = setTimeout(() => loadHistory().catch(() => {}), 60000);
      scheduleRender(0);
    });
  }

  function windowButtons() {
    for (const b of document.querySelectorAll(".window button")) {
      b.setAttribute("aria-pressed", String(Number(b.dataset.window) === state.windowS));
    }
  }

  function addPoint(key, unit, tNs, v, s) {
    let series = state.series.get(key);
    if (!series) {
      series = { unit, resolution: "sample", points: [] };
      state.series.set(key, series);
    }
    if (!isFinite(v)) return;
    const t = nsToMs(tNs);
    const pts = series.points;
    if (pts.length && t <= pts[pts.length - 1].t) return;
    pts.push({ t, v, s, lo: v - 2 * s, hi: v + 2 * s });
    const from = Date.now() + state.clockOffset - state.windowS * 1000;
    while (pts.length > 2 && (pts[0].t < from || pts.length > 4000)) pts.shift();
  }

  // A record from the stream: the latest values and the live end of the charts.
  function applyRecord(r) {
    const d = state.data;
    if (!d || r.site !== state.site || r.unit !== state.unit) return;
    switch (r.topic) {
      case "virtual_sensor":
        d.sensors.set(r.name, r);
        addPoint(`vs/${r.name}`, r.eng_unit, r.timestamp_ns, r.value, r.sigma);
        break;
      case "unit_estimate":
        for (const e of r.estimates) addPoint(`vs/${e.name}`, e.eng_unit, r.timestamp_ns, e.value, e.sigma);
        break;
      case "observation":
        d.observations.set(r.point, r);
        addPoint(`obs/${r.point}/innovation`, "", r.timestamp_ns, r.innovation,
                 Math.sqrt(Math.max(r.innovation_variance, 0)));
        addPoint(`obs/${r.point}/test_ratio`, "", r.timestamp_ns, r.test_ratio, 0);
        break;
      case "estimator_health":
        d.health = r;
        addPoint("health/cycle_time_ms", "ms", r.timestamp_ns, r.cycle_time_ms, 0);
        break;
      case "leak_diagnostic":
        d.leak = r;
        addPoint("leak/charge", "kg", r.timestamp_ns, r.charge, r.charge_sigma);
        addPoint("leak/leak_rate", "g/h", r.timestamp_ns, r.leak_rate, r.leak_rate_sigma);
        addPoint("leak/rate_cusum", "σ", r.timestamp_ns, r.rate_cusum, 0);
        addPoint("leak/charge_cusum", "σ", r.timestamp_ns, r.charge_cusum, 0);
        break;
      case "estimator_consistency":
        d.consistency.set(r.point, r);
        break;
      default:
        return;
    }
    scheduleRender(250);
  }

  function scheduleRender(delay) {
    if (state.renderTimer) return;
    state.renderTimer = setTimeout(() => {
      state.renderTimer = 0;
      if (state.view === "unit" && state.data) renderUnit();
    }, delay);
  }

  function badge(label, value, cls) {
    const b = text("span", "", `badge ${cls || ""}`);
    b.append(text("span", `${label}: `), text("b", value));
    return b;
  }

  function unitStatus() {
    const d = state.data;
    if (!d) return;
    const s = d.summary;
    const leak = leakState(s);
    const box = $("unit-status");
    box.replaceChildren();
    box.dataset.leakState = leak;
    box.dataset.stale = s.stale;
    if (s.stale !== "NO") box.append(badge("Status", `STALE: ${STALE_TEXT[s.stale] || s.stale}`, "stale"));
    if (s.leak) {
      const held = s.leak.hold !== "NONE" ? ` (${(HOLD_TEXT[s.leak.hold] || s.leak.hold)})` : "";
      const since = leak === "LEAK" ? s.leak.leak_since_ns : leak === "SUSPECT" ? s.leak.suspect_since_ns : 0;
      const sinceClock = since > 0 ? ` since ${HvacChart.clock(nsToMs(since), true)}` : "";
      box.append(badge("Leak", `${STATE_ICON[leak]} ${leak}${sinceClock}${held}`,
        leak === "LEAK" ? "bad" : leak === "SUSPECT" ? "warn" : "ok"));
    }
    box.append(badge("Estimate", estimateText(s),
      s.quality === "GOOD" ? "ok" : s.quality === "DEGRADED" ? "warn" : ""));
    if (s.health) {
      box.append(badge("Modbus", s.health.modbus_connected ? "connected" : "DOWN",
        s.health.modbus_connected ? "ok" : "bad"));
      box.append(badge("Last cycle", `#${s.health.cycle} at ${HvacChart.clock(nsToMs(s.health.timestamp_ns), true)}`));
    }
    document.title = `${leak !== "NONE" ? leak + " · " : ""}${state.unit} — hvac-twin`;
  }

  function chart(containerId, id, title) {
    let c = state.charts.get(id);
    if (!c) {
      c = HvacChart.create($(containerId), title);
      c.figure.dataset.chart = id;
      state.charts.set(id, c);
    }
    return c;
  }

  // The points of a series, scaled for display.
  function pointsOf(key) {
    const s = state.series.get(key);
    if (!s) return { points: [], unit: "" };
    const sc = scaleOf(s.unit);
    if (sc.k === 1) return { points: s.points, unit: sc.unit };
    return {
      unit: sc.unit,
      points: s.points.map((p) => ({ t: p.t, v: p.v * sc.k, s: p.s * sc.k, lo: p.lo * sc.k, hi: p.hi * sc.k })),
    };
  }

  // The charts' time range: the window, or less while the unit's history is shorter (a unit
  // that started a few minutes ago fills the chart instead of its right edge).
  function range() {
    const to = Date.now() + state.clockOffset;
    let oldest = to;
    for (const s of state.series.values()) if (s.points.length) oldest = Math.min(oldest, s.points[0].t);
    const from = Math.max(to - state.windowS * 1000, Math.min(oldest, to - 120e3));
    return { from, to };
  }

  function drawSeries(c, key, latest, refs, band) {
    const { points } = pointsOf(key);
    const { from, to } = range();
    HvacChart.draw(c, {
      from, to,
      series: [{ label: key, points, color: COLORS[0], band: band || "value" }],
      refs: refs || [], latest,
      describe: `${latest}; ${points.length} points in the window`,
    });
  }

  function renderUnit() {
    const d = state.data;
    unitStatus();
    const { from, to } = range();

    // Charge and leak detection.
    $("leak-none").hidden = !!d.leak;
    if (d.leak) {
      const l = d.leak;
      const refs = [{ y: l.nameplate_charge, label: `nameplate ${l.nameplate_charge.toFixed(3)}`, color: "#4d5761" }];
      if (l.charge_reference > 0) refs.push({ y: l.charge_reference, label: `commissioned ${l.charge_reference.toFixed(3)}`, color: "#2e7d32" });
      drawSeries(chart("leak-charts", "charge", "Refrigerant charge (kg)"), "leak/charge",
        valueText(l.charge, l.charge_sigma, "kg"), refs);
      const c = chart("leak-charts", "cusum", "Leak CUSUMs against the threshold (σ)");
      HvacChart.draw(c, {
        from, to,
        series: [
          { label: "rate", points: pointsOf("leak/rate_cusum").points, color: COLORS[0], band: "none" },
          { label: "charge", points: pointsOf("leak/charge_cusum").points, color: COLORS[1], band: "none", dash: "4 2" },
        ],
        refs: [{ y: l.threshold, label: `LEAK ${l.threshold.toFixed(2)}`, color: "#8f1414" },
               { y: l.threshold / 2, label: `SUSPECT ${(l.threshold / 2).toFixed(2)}`, color: "#8a5a00", below: true }],
        latest: `rate ${l.rate_cusum.toFixed(2)} · charge ${l.charge_cusum.toFixed(2)}`,
        legend: "solid: on the leak rate · dashed: on the charge deficit",
        describe: `rate CUSUM ${l.rate_cusum.toFixed(2)}, charge CUSUM ${l.charge_cusum.toFixed(2)}, threshold ${l.threshold.toFixed(2)}`,
      });
      drawSeries(chart("leak-charts", "leak_rate", "Leak rate (g/h)"), "leak/leak_rate",
        valueText(l.leak_rate, l.leak_rate_sigma, "g/h"), [{ y: 0, label: "0", color: "#4d5761" }]);
    }

    // Virtual sensors: the key figures first, the rest below.
    const names = [...d.sensors.keys()];
    const key = KEY_SENSORS.filter((n) => d.sensors.has(n));
    const other = names.filter((n) => !KEY_SENSORS.includes(n));
    for (const [container, list] of [["key-charts", key], ["other-charts", other]]) {
      for (const n of list) {
        const r = d.sensors.get(n);
        const sc = scaleOf(r.eng_unit);
        drawSeries(chart(container, `vs/${n}`, `${n.replace(/_/g, " ")}${sc.unit && sc.unit !== "1" ? " (" + sc.unit + ")" : ""}`),
          `vs/${n}`, valueText(r.value, r.sigma, r.eng_unit));
      }
    }
    $("key-title").hidden = key.length === 0;

    // Measured points.
    const body = $("points").tBodies[0];
    body.replaceChildren();
    for (const [point, o] of d.observations) {
      const tr = document.createElement("tr");
      const sd = Math.sqrt(Math.max(o.innovation_variance, 0));
      const dec = decimalsFor(2 * sd);
      const c = d.consistency.get(point);
      const cells = [
        point, num(o.value, dec), num(o.predicted, dec),
        `${o.innovation >= 0 ? "+" : ""}${num(o.innovation, dec)} ± ${num(2 * sd, dec)}`,
        num(o.test_ratio, 2), o.fused ? "yes" : "no", o.quality,
        c ? `${num(c.mean_nis, 2)} [${num(c.band_low, 2)}, ${num(c.band_high, 2)}] ${c.verdict}` +
            `${c.rejected_share > 0 ? `, ${(100 * c.rejected_share).toFixed(1)} % rejected` : ""}` : "–",
      ];
      cells.forEach((v, i) => {
        const td = text(i === 0 ? "th" : "td", v);
        if (i === 0) td.scope = "row";
        if ((i === 6 && o.quality !== "GOOD") || (i === 7 && c && c.verdict === "HIGH")) td.className = "bad";
        tr.append(td);
      });
      body.append(tr);
      drawSeries(chart("point-charts", `inn/${point}`, `${point.replace(/_/g, " ")}: innovation`),
        `obs/${point}/innovation`, `${o.innovation >= 0 ? "+" : ""}${num(o.innovation, dec)} ± ${num(2 * sd, dec)}`,
        [{ y: 0, label: "", color: "#4d5761" }], "zero");
      drawSeries(chart("point-charts", `nis/${point}`, `${point.replace(/_/g, " ")}: test ratio (NIS)`),
        `obs/${point}/test_ratio`, num(o.test_ratio, 2), [{ y: 1, label: "expected 1", color: "#4d5761" }], "none");
    }

    // Health.
    const h = d.health;
    const dl = $("health");
    dl.replaceChildren();
    if (h) {
      const rows = [
        ["Cycle", `#${h.cycle}`], ["Cycle time", `${num(h.cycle_time_ms, 1)} ms (max ${num(h.cycle_time_max_ms, 1)})`],
        ["Quality", h.quality], ["Deadline overruns", h.overruns], ["Degraded cycles", h.degraded_cycles],
        ["Gate rejections", h.gate_rejections], ["Numerical resets", h.numerical_resets],
        ["Publish rejections", h.publish_rejections],
        ["Modbus", h.modbus_connected ? "connected" : "DOWN"], ["Polls ok", h.modbus_polls_ok],
        ["Polls with exception", h.modbus_polls_exception], ["Polls failed", h.modbus_polls_failed],
        ["Reconnects", h.modbus_reconnects], ["Last Modbus error", h.modbus_last_error || "none"],
      ];
      for (const [k, v] of rows) dl.append(text("dt", k), text("dd", String(v)));
      drawSeries(chart("health-charts", "cycle_time", "Cycle time (ms)"), "health/cycle_time_ms",
        `${num(h.cycle_time_ms, 1)} ms`, [], "none");
    }
    footer();
  }

  // --- Routing and timers -----------------------------------------------------------------------

  function route() {
    const m = location.hash.match(/^#\/unit\/([^/]+)\/([^/]+)$/);
    if (m) showUnit(decodeURIComponent(m[1]), decodeURIComponent(m[2]));
    else showOverview();
  }

  document.querySelector(".window").addEventListener("click", (e) => {
    const b = e.target.closest("button[data-window]");
    if (!b) return;
    const w = Number(b.dataset.window);
    if (!WINDOWS.includes(w) || w === state.windowS) return;
    state.windowS = w;
    windowButtons();
    if (state.view === "unit") loadHistory().catch(() => {});
  });
  window.addEventListener("hashchange", route);
  setInterval(() => {
    if (state.view === "overview") for (const li of document.querySelectorAll("li.tile")) ageTile(li);
  }, 1000);
  route();
})();
