"use strict";
// The report page's controls: filter, failures only, sort; per entry the
// views (side by side, flick, swipe), zoom, amplified difference and pixel
// probe. Names only ever enter the page as text; nothing here parses markup.
(() => {
  const $ = (sel, root = document) => root.querySelector(sel);
  const $$ = (sel, root = document) => Array.from(root.querySelectorAll(sel));
  const pixels = JSON.parse($("#pixels").textContent || "{}");
  const decoded = {};
  // Both images' RGBA codes, decoded from the page's data URLs on first use
  // (a promise; null when the page carries none for this entry).
  const codes = (place) => {
    if (!(place in pixels)) return Promise.resolve(null);
    const read = (url) => new Promise((done, failed) => {
      const img = new Image();
      img.onload = () => {
        const canvas = document.createElement("canvas");
        canvas.width = img.naturalWidth; canvas.height = img.naturalHeight;
        const context = canvas.getContext("2d");
        context.drawImage(img, 0, 0);
        done(context.getImageData(0, 0, canvas.width, canvas.height).data);
      };
      img.onerror = failed;
      img.src = url;
    });
    decoded[place] ??= Promise.all([read(pixels[place].reference), read(pixels[place].actual)])
      .then(([reference, actual]) => ({ reference, actual }));
    return decoded[place];
  };
  const toLinear = (c) => { const v = c / 255; return v <= 0.04045 ? v / 12.92 : Math.pow((v + 0.055) / 1.055, 2.4); };

  // Filter, failures only and sort.
  const entries = $$("article.entry");
  const filterBox = $("#filter"), failuresOnly = $("#failures-only"), sortBy = $("#sort"), sortDir = $("#sort-dir");
  function applyFilter() {
    const text = filterBox.value.trim().toLowerCase();
    let shown = 0;
    for (const e of entries) {
      const hide = (text && !e.dataset.name.toLowerCase().includes(text)) ||
        (failuresOnly.checked && !e.classList.contains("failed"));
      e.classList.toggle("hidden-by-filter", hide);
      if (!hide) shown++;
    }
    for (const g of $$(".group")) {
      g.classList.toggle("hidden-by-filter", !$$("article.entry:not(.hidden-by-filter)", g).length);
    }
    $("#shown").textContent = shown === entries.length ? "" : `${shown} of ${entries.length} shown`;
  }
  function applySort() {
    const key = sortBy.value, down = sortDir.dataset.down === "1";
    const value = (e) => key === "name" ? e.dataset.name : parseFloat(e.dataset[key]);
    for (const g of $$(".group")) {
      const items = $$(":scope > article.entry", g);
      items.sort((a, b) => {
        const [x, y] = [value(a), value(b)];
        const missing = (v) => typeof v === "number" && Number.isNaN(v);
        if (missing(x) || missing(y)) return missing(x) - missing(y);
        const order = key === "name" ? x.localeCompare(y) : x - y;
        return (down ? -order : order) || a.dataset.place - b.dataset.place;
      });
      items.forEach((e) => g.appendChild(e));
    }
  }
  filterBox.addEventListener("input", applyFilter);
  failuresOnly.addEventListener("change", applyFilter);
  sortBy.addEventListener("change", () => {
    // Figures read best largest first; name and manifest order in reading order.
    sortDir.dataset.down = ["place", "name"].includes(sortBy.value) ? "0" : "1";
    sortDir.textContent = sortDir.dataset.down === "1" ? "descending" : "ascending";
    applySort();
  });
  sortDir.addEventListener("click", () => {
    sortDir.dataset.down = sortDir.dataset.down === "1" ? "0" : "1";
    sortDir.textContent = sortDir.dataset.down === "1" ? "descending" : "ascending";
    applySort();
  });

  // Copy buttons.
  for (const b of $$("button.copy")) {
    b.addEventListener("click", () => {
      const text = $("code.command", b.parentElement).textContent;
      const done = () => { b.textContent = "copied"; setTimeout(() => (b.textContent = "copy"), 1500); };
      if (navigator.clipboard) navigator.clipboard.writeText(text).then(done, () => {});
    });
  }

  // One entry's images.
  function setUp(viewer) {
    const place = viewer.dataset.place, w = +viewer.dataset.w, h = +viewer.dataset.h;
    const hasData = place in pixels;
    const probe = $(".probe", viewer), amp = $(".amp", viewer), zoom = $(".zoom", viewer);
    const views = $$(".view", viewer), tabs = $$(".tabs button", viewer);
    const flicker = $(".flicker", viewer), flickLabel = $(".flick-label", viewer);
    const top = $(".swipe-top", viewer), divider = $(".divider", viewer), position = $(".swipe-position", viewer);
    const box = $(".swipe-box", viewer);
    const api = {};

    api.show = (name) => {
      views.forEach((v) => (v.hidden = !v.classList.contains(name)));
      tabs.forEach((t) => t.classList.toggle("on", t.dataset.view === name));
    };
    tabs.forEach((t) => t.addEventListener("click", () => api.show(t.dataset.view)));

    api.zoom = (z) => {
      zoom.value = z;
      for (const img of $$("img.px", viewer)) { img.width = w * z; img.height = h * z; }
    };
    zoom.addEventListener("input", () => api.zoom(+zoom.value));

    api.flick = () => {
      const toActual = flicker.dataset.role === "reference";
      flicker.dataset.role = toActual ? "actual" : "reference";
      flicker.src = toActual ? flicker.dataset.actual : flicker.dataset.reference;
      flickLabel.textContent = flicker.dataset.role;
    };
    flicker.addEventListener("click", api.flick);

    api.swipe = (percent) => {
      position.value = percent;
      top.style.clipPath = `inset(0 ${100 - percent}% 0 0)`;
      divider.style.left = `${percent}%`;
    };
    position.addEventListener("input", () => api.swipe(+position.value));
    const drag = (e) => {
      if (e.buttons !== 1 && e.type !== "pointerdown") return;
      const r = box.getBoundingClientRect();
      api.swipe(Math.round(Math.min(100, Math.max(0, (100 * (e.clientX - r.left)) / r.width))));
    };
    box.addEventListener("pointerdown", drag);
    box.addEventListener("pointermove", drag);

    const diffImage = $("img[data-role=difference]", viewer), ampValue = $(".amp-value", viewer);
    api.amplify = async (k) => {
      amp.value = String(k);
      ampValue.textContent = k;
      const data = await codes(place);
      if (!data) return;
      const canvas = document.createElement("canvas");
      canvas.width = w; canvas.height = h;
      const context = canvas.getContext("2d"), out = context.createImageData(w, h);
      for (let i = 0; i < w * h * 4; i += 4) {
        for (let c = 0; c < 3; c++) out.data[i + c] = Math.min(255, Math.abs(data.actual[i + c] - data.reference[i + c]) * k);
        out.data[i + 3] = 255;
      }
      context.putImageData(out, 0, 0);
      diffImage.src = canvas.toDataURL("image/png");
    };
    if (hasData) amp.addEventListener("change", () => api.amplify(+amp.value));
    else { amp.disabled = true; amp.title = "this image is too large for the page to amplify"; }

    api.probeAt = async (img, clientX, clientY) => {
      const r = img.getBoundingClientRect();
      const x = Math.floor(((clientX - r.left) / r.width) * w), y = Math.floor(((clientY - r.top) / r.height) * h);
      if (x < 0 || y < 0 || x >= w || y >= h) return;
      const data = await codes(place);
      if (!data) { probe.textContent = `(${x}, ${y})`; return; }
      const i = 4 * (y * w + x);
      const triple = (a) => [a[i], a[i + 1], a[i + 2]];
      const [ref, act] = [triple(data.reference), triple(data.actual)];
      const linear = (t) => t.map((c) => toLinear(c).toFixed(4)).join(" ");
      const delta = Math.max(...ref.map((c, k) => Math.abs(toLinear(act[k]) - toLinear(c))));
      probe.textContent = `(${x}, ${y})  reference ${ref.join(" ")} [${linear(ref)}]  actual ${act.join(" ")} ` +
        `[${linear(act)}]  largest linear difference ${delta.toFixed(4)}`;
    };
    for (const img of $$("img.px", viewer)) {
      img.addEventListener("mousemove", (e) => api.probeAt(img, e.clientX, e.clientY));
    }
    box.addEventListener("mousemove", (e) => api.probeAt(box, e.clientX, e.clientY));
    viewer.api = api;
    return api;
  }
  $$(".viewer").forEach(setUp);

  // F flicks every flick view on screen.
  document.addEventListener("keydown", (e) => {
    if ((e.key === "f" || e.key === "F") && e.target.tagName !== "INPUT") {
      for (const v of $$(".viewer")) if (!$(".view.flick", v).hidden) v.api.flick();
    }
  });

  applyFilter();
  if (new URLSearchParams(location.search).has("selftest")) window.addEventListener("load", selftest);
  // How long the page took to load, for the benchmark that times it.
  window.addEventListener("load", () => {
    const timing = performance.getEntriesByType("navigation")[0];
    if (timing) document.body.dataset.loadMs = Math.round(timing.loadEventStart);
  });

  // Exercises the controls as a person would and writes what failed into #selftest.
  async function selftest() {
    const problems = [];
    const check = (ok, what) => { if (!ok) problems.push(what); };
    const v = $(".viewer");
    if (v) {
      const api = v.api;
      api.show("flick");
      const flicker = $(".flicker", v);
      check(!$(".view.flick", v).hidden && $(".view.side", v).hidden, "the flick tab shows the flick view alone");
      const first = flicker.getAttribute("src");
      flicker.click();
      check(flicker.getAttribute("src") === flicker.dataset.actual && first === flicker.dataset.reference, "a click flicks to the actual");
      document.dispatchEvent(new KeyboardEvent("keydown", { key: "f" }));
      check(flicker.getAttribute("src") === flicker.dataset.reference, "F flicks back to the reference");
      api.show("swipe");
      const position = $(".swipe-position", v);
      position.value = "30";
      position.dispatchEvent(new Event("input"));
      check($(".swipe-top", v).style.clipPath === "inset(0px 70% 0px 0px)", `the swipe divides at 30%: ${$(".swipe-top", v).style.clipPath}`);
      api.show("side");
      const diff = $("img[data-role=difference]", v);
      await api.amplify(1);
      const once = diff.src;
      await api.amplify(64);
      check(diff.src.startsWith("data:image/png") && diff.src !== once, "the difference amplifies");
      const img = $("img[data-role=reference]", v), r = img.getBoundingClientRect();
      await api.probeAt(img, r.left + 1, r.top + 1);
      const probed = $(".probe", v).textContent;
      check(probed.startsWith("(0, 0)  reference"), `the probe reads pixel (0, 0): ${probed}`);
      api.zoom(7);
      check(img.width === 7 * +v.dataset.w, "the zoom scales the images");
    }
    const name = entries.length ? entries[entries.length - 1].dataset.name : "";
    filterBox.value = name;
    filterBox.dispatchEvent(new Event("input"));
    check(entries.every((e) => e.classList.contains("hidden-by-filter") !== e.dataset.name.toLowerCase().includes(name.toLowerCase())), "the filter shows the matching entries alone");
    filterBox.value = "";
    filterBox.dispatchEvent(new Event("input"));
    failuresOnly.checked = true;
    failuresOnly.dispatchEvent(new Event("change"));
    check(entries.every((e) => e.classList.contains("hidden-by-filter") !== e.classList.contains("failed")), "failures only hides the rest");
    failuresOnly.checked = false;
    failuresOnly.dispatchEvent(new Event("change"));
    sortBy.value = "max";
    sortBy.dispatchEvent(new Event("change"));
    for (const g of $$(".group")) {
      const values = $$(":scope > article.entry", g).map((e) => parseFloat(e.dataset.max)).filter((x) => !Number.isNaN(x));
      check(values.every((x, i) => i === 0 || values[i - 1] >= x), `sorted by largest difference, largest first: ${values}`);
    }
    const out = document.createElement("output");
    out.id = "selftest";
    out.textContent = problems.length ? `fail: ${problems.join("; ")}` : "pass";
    document.body.prepend(out);
  }
})();
