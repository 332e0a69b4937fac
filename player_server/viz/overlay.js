/* murdoch's page around the meshcat view: robot labels, clock, legend, replay controls.
 *
 * The live view and replay.html both load this file. It reads the data objects the scene
 * carries (player_server/viz/hud.py: robots/<name>/info, hud/clock, hud/legend) or, in a
 * replay, the embedded timeline, and draws plain HTML over the 3-D view. What the page shows
 * is also written, as JSON, into #murdoch-state (the clock, every robot's pose as drawn and
 * every label's rectangle), so that a browser test can read it.
 */
var MurdochOverlay = (function () {
  "use strict";

  function overlaps(a, b, gap) {
    return a.left < b.left + b.width + gap && b.left < a.left + a.width + gap &&
      a.top < b.top + b.height + gap && b.top < a.top + a.height + gap;
  }

  /* Pure: places each label near its anchor so that no two labels overlap (and, where it
   * can, no label covers a robot). items: [{id, x, y, width, height}] with the anchor (x, y)
   * and the label's size in pixels. Returns {id: {left, top}}. Candidates are tried in
   * order (above right, above left, below right, below left, then one label height further
   * out each ring); a label that fits nowhere goes below every label placed so far. */
  function placeLabels(items, opts) {
    opts = opts || {};
    var gap = opts.gap === undefined ? 3 : opts.gap;
    var reach = opts.reach === undefined ? 9 : opts.reach;
    var rings = opts.rings === undefined ? 8 : opts.rings;
    var order = items.slice().sort(function (a, b) { return (a.y - b.y) || (a.x - b.x); });
    var anchors = items.map(function (it) {
      return {left: it.x - reach, top: it.y - reach, width: 2 * reach, height: 2 * reach};
    });
    var placed = [];
    var out = {};
    function free(r, strict) {
      for (var i = 0; i < placed.length; i++) {
        if (overlaps(r, placed[i], gap)) { return false; }
      }
      if (strict) {
        for (var j = 0; j < anchors.length; j++) {
          if (overlaps(r, anchors[j], 0)) { return false; }
        }
      }
      return true;
    }
    order.forEach(function (it) {
      var w = it.width, h = it.height, rect = null;
      var offsets = [];
      for (var k = 0; k <= rings; k++) {
        var dy = k * (h + gap);
        offsets.push([reach, -reach - h - dy], [-reach - w, -reach - h - dy],
                     [reach, reach + dy], [-reach - w, reach + dy],
                     [-w / 2, -reach - h - dy], [-w / 2, reach + dy]);
      }
      for (var pass = 0; pass < 2 && rect === null; pass++) {
        for (var c = 0; c < offsets.length; c++) {
          var r = {left: it.x + offsets[c][0], top: it.y + offsets[c][1], width: w, height: h};
          if (free(r, pass === 0)) { rect = r; break; }
        }
      }
      if (rect === null) {
        var bottom = it.y;
        placed.forEach(function (p) { bottom = Math.max(bottom, p.top + p.height); });
        rect = {left: it.x + reach, top: bottom + gap + 1, width: w, height: h};
      }
      placed.push(rect);
      out[it.id] = {left: rect.left, top: rect.top};
    });
    return out;
  }

  /* "7:40", "1:07:40", "460" or "460.5" -> seconds; null when it is none of these. */
  function parseMoment(text) {
    if (typeof text !== "string") { return null; }
    var m = /^\s*(?:(\d+):)?(?:(\d+):)?(\d+(?:\.\d+)?)\s*$/.exec(text);
    if (!m) { return null; }
    var parts = [m[1], m[2], m[3]].filter(function (p) { return p !== undefined; });
    var s = 0;
    parts.forEach(function (p) { s = s * 60 + parseFloat(p); });
    return s;
  }

  function clockText(t) {
    var s = Math.floor(Math.max(0, t));
    var h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60);
    return "sim " + h + ":" + String(m).padStart(2, "0") + ":" + String(s % 60).padStart(2, "0");
  }

  function el(tag, attrs, parent) {
    var e = document.createElement(tag);
    Object.keys(attrs || {}).forEach(function (k) { e.setAttribute(k, attrs[k]); });
    if (parent) { parent.appendChild(e); }
    return e;
  }

  function swatch(colour, shape, parent) {
    var s = el("span", {"class": "mo-sw mo-" + shape}, parent);
    if (shape === "ring") {
      s.style.borderColor = colour;
    } else {
      s.style.background = colour;
    }
    return s;
  }

  function Overlay(viewer, options) {
    this.viewer = viewer;
    this.replay = options.replay || null;  // {speed, duration, timeline}
    this.pane = document.getElementById("meshcat-pane");
    this.box = el("div", {id: "murdoch-overlay"}, document.body);
    this.svg = document.createElementNS("http://www.w3.org/2000/svg", "svg");
    this.svg.setAttribute("id", "murdoch-leaders");
    this.box.appendChild(this.svg);
    this.clock = el("div", {id: "murdoch-clock"}, document.body);
    this.legend = el("div", {id: "murdoch-legend"}, document.body);
    this.state = el("pre", {id: "murdoch-state"}, document.body);
    this.labels = {};
    this.legendKey = "";
    this.live = {t: null, frames: 0, robots: {}};
    this.placed = {};
    if (this.replay) {
      this.setupReplay();
    } else {
      this.hookLive();
    }
  }

  Overlay.prototype.find = function () {
    var robots = [], clock = null, legend = null;
    this.viewer.scene.traverse(function (o) {
      var d = o.userData;
      if (o.name !== "murdoch-data" || !d || !d.murdoch) { return; }
      if (d.murdoch === "robot") {
        robots.push({data: d, body: o.parent && o.parent.parent});
      } else if (d.murdoch === "clock") {
        clock = d;
      } else if (d.murdoch === "legend") {
        legend = d;
      }
    });
    return {robots: robots, clock: clock, legend: legend};
  };

  /* Each robot's (x, y, yaw) in the scene's frame (meshcat's z-up world; the groups above
   * the robots are never moved). */
  Overlay.prototype.poses = function (robots) {
    var out = {};
    robots.forEach(function (r) {
      if (!r.body) { return; }
      var p = r.body.position, q = r.body.quaternion;
      out[r.data.name] = [p.x, p.y, 2 * Math.atan2(q.z, q.w)];
    });
    return out;
  };

  /* Live: the clock closes each frame of the feed; the poses then are that frame's. */
  Overlay.prototype.hookLive = function () {
    var self = this, viewer = this.viewer;
    var handle = viewer.handle_command.bind(viewer);
    viewer.handle_command = function (cmd) {
      handle(cmd);
      if (cmd.type === "set_object" && /\/hud\/clock$/.test(cmd.path || "")) {
        var found = self.find();
        self.live = {t: found.clock ? found.clock.t : null, frames: self.live.frames + 1,
                     robots: self.poses(found.robots)};
      }
    };
  };

  Overlay.prototype.setupReplay = function () {
    var self = this, rp = this.replay;
    var bar = el("div", {id: "murdoch-replay"}, document.body);
    this.playButton = el("button", {id: "murdoch-play", type: "button"}, bar);
    this.slider = el("input", {id: "murdoch-slider", type: "range", min: "0",
                               max: String(rp.duration), step: "0.5", value: "0"}, bar);
    this.playButton.textContent = "pause";
    this.playButton.addEventListener("click", function () {
      var a = self.viewer.animator;
      if (a.playing) { a.pause(); } else {
        if (self.replayTime() >= rp.duration - 1e-6) { a.seek(0); }
        a.play();
      }
    });
    this.slider.addEventListener("input", function () {
      self.seek(parseFloat(self.slider.value));
      history.replaceState(null, "", "#t=" + clockText(self.replayTime()).slice(4));
    });
    var fromHash = function () {
      var m = /(?:^|[#&])t=([^&]*)/.exec(location.hash);
      var t = m ? parseMoment(decodeURIComponent(m[1])) : null;
      if (t !== null) { self.seek(t); }
    };
    window.addEventListener("hashchange", fromHash);
    fromHash();
  };

  Overlay.prototype.seek = function (t) {
    var a = this.viewer.animator, rp = this.replay;
    a.pause();
    a.seek(Math.max(0, Math.min(rp.duration, t)) / rp.speed);
    this.refresh();
  };

  Overlay.prototype.replayTime = function () {
    var acts = this.viewer.animator.actions;
    return acts.length ? Math.min(this.replay.duration, acts[0].time * this.replay.speed) : 0;
  };

  function at(changes, t) {
    // changes: [[t, ...values], ...] sorted by t; the last at or before t
    var lo = 0, hi = changes.length - 1, found = null;
    while (lo <= hi) {
      var mid = (lo + hi) >> 1;
      if (changes[mid][0] <= t + 1e-6) { found = changes[mid]; lo = mid + 1; } else { hi = mid - 1; }
    }
    return found;
  }

  Overlay.prototype.infoAt = function (name, base, t) {
    var tl = this.replay.timeline[name];
    var c = tl ? at(tl, t) : null;
    if (!c) { return base; }
    return {murdoch: "robot", name: name, state: c[1], stateColour: c[2], battery: c[3],
            task: c[4], colour: c[5], marked: c[6]};
  };

  Overlay.prototype.label = function (name) {
    var l = this.labels[name];
    if (!l) {
      l = {div: el("div", {"class": "mo-label", "data-robot": name}, this.box), key: ""};
      l.line = document.createElementNS("http://www.w3.org/2000/svg", "line");
      this.svg.appendChild(l.line);
      this.labels[name] = l;
    }
    return l;
  };

  Overlay.prototype.fill = function (l, d) {
    var key = JSON.stringify(d);
    if (key === l.key) { return; }
    l.key = key;
    var div = l.div;
    div.textContent = "";
    div.style.borderColor = d.stateColour || "#333";
    var head = el("div", {"class": "mo-head"}, div);
    swatch(d.stateColour || "#333", "square", head);
    el("b", {}, head).textContent = d.name;
    var rest = " " + (d.battery === null || d.battery === undefined ? "" : d.battery + "%");
    head.appendChild(document.createTextNode(rest + " " + (d.state === "failed" ? "down" : d.state)));
    if (d.task) {
      var task = el("div", {"class": "mo-task"}, div);
      var cut = d.task.indexOf(": ");
      var kind = cut >= 0 ? d.task.slice(0, cut) : d.task;
      var target = cut >= 0 ? d.task.slice(cut + 2) : "";
      task.appendChild(document.createTextNode(kind + (target ? " \u2192 " : "")));
      if (d.colour) { swatch(d.colour, d.marked ? "marked" : "square", task); }
      if (target) { task.appendChild(document.createTextNode(target)); }
    }
  };

  Overlay.prototype.drawLegend = function (legend) {
    var key = JSON.stringify(legend ? legend.entries : null);
    if (key === this.legendKey) { return; }
    this.legendKey = key;
    var box = this.legend;
    box.textContent = "";
    (legend ? legend.entries : []).forEach(function (e) {
      var row = el("div", {"class": "mo-entry"}, box);
      e.colours.forEach(function (c) { swatch(c, e.shape, row); });
      row.appendChild(document.createTextNode(" " + e.label));
    });
  };

  Overlay.prototype.refresh = function () {
    var viewer = this.viewer, self = this;
    var found = this.find();
    var t = null;
    if (this.replay) {
      t = this.replayTime();
      if (!viewer.animator.playing && this.playButton) { this.playButton.textContent = "play"; }
      if (viewer.animator.playing && this.playButton) { this.playButton.textContent = "pause"; }
      if (document.activeElement !== this.slider) { this.slider.value = String(t); }
    } else if (found.clock) {
      t = found.clock.t;
    }
    this.clock.textContent = t === null ? "" : clockText(t);
    this.drawLegend(found.legend || (this.replay && this.replay.legend));
    // the camera as the next render will have it (the viewer renders on animation frames,
    // which a hidden or headless page may not get between two refreshes)
    var camera = viewer.camera;
    if (camera.isPerspectiveCamera && viewer.dom_element &&
        Math.abs(camera.aspect - viewer.dom_element.offsetWidth / window.innerHeight) > 1e-6) {
      viewer.set_3d_pane_size();
    }
    if (viewer.controls) { viewer.controls.update(); }
    camera.updateProjectionMatrix();
    viewer.scene.updateMatrixWorld(true);
    var canvas = viewer.renderer.domElement;
    var w = canvas.clientWidth || window.innerWidth, h = canvas.clientHeight || window.innerHeight;
    var poses = this.poses(found.robots);
    var items = [], infos = {};
    found.robots.forEach(function (r) {
      var name = r.data.name, p = poses[name];
      if (!p) { return; }
      var d = self.replay ? self.infoAt(name, r.data, t) : r.data;
      infos[name] = d;
      var l = self.label(name);
      self.fill(l, d);
      var v = r.body.localToWorld(new (r.body.position.constructor)(0, 0, 0.3));
      v.project(camera);
      l.anchor = [(v.x + 1) / 2 * w, (1 - v.y) / 2 * h];
      l.visible = v.z < 1;
      if (l.visible) {
        items.push({id: name, x: l.anchor[0], y: l.anchor[1],
                    width: l.div.offsetWidth, height: l.div.offsetHeight});
      }
    });
    var placed = placeLabels(items);
    var rects = {}, anchors = {};
    Object.keys(this.labels).forEach(function (name) {
      var l = self.labels[name], p = placed[name];
      if (!p) { l.div.style.display = "none"; l.line.setAttribute("visibility", "hidden"); return; }
      l.div.style.display = "";
      l.div.style.left = p.left + "px";
      l.div.style.top = p.top + "px";
      var r = l.div.getBoundingClientRect();
      rects[name] = [r.left, r.top, r.width, r.height];
      anchors[name] = l.anchor;
      var lx = Math.max(r.left, Math.min(l.anchor[0], r.right));
      var ly = Math.max(r.top, Math.min(l.anchor[1], r.bottom));
      l.line.setAttribute("x1", l.anchor[0]); l.line.setAttribute("y1", l.anchor[1]);
      l.line.setAttribute("x2", lx); l.line.setAttribute("y2", ly);
      l.line.setAttribute("visibility", "visible");
    });
    var live = this.replay ? {t: t, robots: poses} : this.live;
    this.state.textContent = JSON.stringify({
      mode: this.replay ? "replay" : "live", t: live.t, clock: this.clock.textContent,
      frames: this.replay ? null : live.frames, robots: live.robots, labels: rects,
      anchors: anchors, view: [window.innerWidth, window.innerHeight],
      info: infos, legend: this.legend.children.length,
      playing: this.replay ? !!viewer.animator.playing : null,
      slider: this.replay ? parseFloat(this.slider.value) : null});
  };

  function attach(viewer, options) {
    var overlay = new Overlay(viewer, options || {});
    var last = 0;
    var tick = function () { last = Date.now(); overlay.refresh(); };
    setInterval(tick, 100);  // also while the page is hidden (no animation frames then)
    // at once when the page changes size (after the viewer's own handler has resized the 3-D
    // view), so that labels never wait for the next tick at the old size
    window.addEventListener("resize", tick);
    var frame = function () {
      if (Date.now() - last >= 33) { tick(); }  // labels follow at up to 30 Hz
      window.requestAnimationFrame(frame);
    };
    window.requestAnimationFrame(frame);
    tick();
    return overlay;
  }

  return {placeLabels: placeLabels, parseMoment: parseMoment, clockText: clockText,
          attach: attach};
})();
