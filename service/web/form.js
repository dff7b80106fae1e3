// A form generated from a method's params JSON Schema (pydantic's output): numbers,
// enums, booleans, strings, nested objects, lists, nullable fields and tagged unions.
// The description is the help text, the method's example the starting values; the
// schema's bounds are checked here, and the server's 422s are shown at the field
// their `loc` points to. DomainIn fields take the drawn domain, MeshIn the uploaded mesh.

let uid = 0;

function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null || v === false) continue;
    if (k === "class") node.className = v;
    else if (k === "text") node.textContent = v;
    else if (k.startsWith("on")) node.addEventListener(k.slice(2), v);
    else node.setAttribute(k, v === true ? "" : v);
  }
  for (const c of children) if (c) node.append(c);
  return node;
}

const isNull = (s) => s && s.type === "null";

export class SchemaForm {
  /**
   * @param schema the params JSON Schema (with $defs)
   * @param example starting values
   * @param ctx {domain(): geometry|null, mesh(): JSON mesh|null, onDomainError(loc, msg)}
   */
  constructor(schema, example, ctx) {
    this.defs = schema.$defs || {};
    this.ctx = ctx;
    this.nodes = new Map(); // JSON path -> node (for server errors)
    this.root = this.make(schema, example ?? {}, [], "params", true);
    this.el = this.root.el;
  }

  deref(s) {
    while (s && s.$ref) s = this.defs[s.$ref.split("/").pop()];
    return s || {};
  }

  /** The params to send; throws nothing (check() first). */
  value() {
    const v = this.root.get();
    return v === undefined ? {} : v;
  }

  /** Client-side checks: [{path, msg}], each also shown next to its field. */
  check() {
    this.clearErrors();
    const errors = this.root.check();
    for (const e of errors) this.showAt(e.path, e.msg);
    return errors;
  }

  clearErrors() {
    for (const node of this.nodes.values()) node.setError?.("");
  }

  /** Show a server 422's errors; returns those no field took. */
  showServerErrors(errors) {
    const rest = [];
    for (const e of errors || []) {
      let loc = e.loc || [];
      if (loc[0] === "body") loc = loc.slice(1);
      if (loc[0] === "params") loc = loc.slice(1);
      if (!this.showAt(loc, e.msg)) rest.push(e);
    }
    return rest;
  }

  showAt(loc, msg) {
    for (let n = loc.length; n >= 1; n--) {
      const node = this.nodes.get(JSON.stringify(loc.slice(0, n)));
      if (node && node.setError) {
        node.setError(msg, loc.slice(n));
        return true;
      }
    }
    return false;
  }

  register(path, node) {
    this.nodes.set(JSON.stringify(path), node);
    return node;
  }

  // ------------------------------------------------------------------ builders

  make(schema, value, path, name, required, outerDescription) {
    const s = this.deref(schema);
    const description = outerDescription || schema.description || s.description || "";
    const variants = s.anyOf || s.oneOf;
    if (variants) {
      const options = variants.filter((v) => !isNull(this.deref(v)));
      if (options.length < variants.length && options.length === 1) {
        return this.optional(options[0], value, path, name, description);
      }
      if (s.discriminator || options.every((o) => this.tag(this.deref(o)))) {
        return this.union(s, options, value, path, name, description, options.length < variants.length);
      }
      return this.json(s, value, path, name, required, description);
    }
    if (s.title === "DomainIn") return this.domain(path, name, description);
    if (s.title === "MeshIn") return this.mesh(value, path, name, description);
    if (s.const !== undefined) return { el: null, get: () => s.const, check: () => [] };
    if (s.enum) return this.select(s, value, path, name, description);
    if (s.type === "boolean") return this.checkbox(s, value, path, name, description);
    if (s.type === "number" || s.type === "integer") return this.number(s, value, path, name, required, description);
    if (s.type === "string") return this.text(s, value, path, name, required, description);
    if (s.type === "object" && s.properties) return this.object(s, value, path, name, description);
    if (s.type === "array") {
      const items = this.deref(s.items || {});
      if ((items.type === "number" || items.type === "integer") && s.maxItems && s.maxItems <= 4) {
        return this.tuple(s, items, value, path, name, required, description);
      }
      if ((items.type === "object" && items.properties) || items.oneOf || items.anyOf) {
        return this.list(s, value, path, name, description);
      }
    }
    return this.json(s, value, path, name, required, description);
  }

  tag(s) {
    for (const [k, p] of Object.entries(s.properties || {})) {
      if (p.const !== undefined) return [k, p.const];
    }
    return null;
  }

  /** label + help + control + error line, wired for screen readers. */
  row(name, description, control, id, extraClass = "") {
    const help = description ? el("small", { class: "help", id: `${id}-help`, text: description }) : null;
    const error = el("span", { class: "field-error", id: `${id}-error`, role: "alert" });
    if (control.setAttribute) {
      control.setAttribute("aria-describedby", [help && help.id, error.id].filter(Boolean).join(" "));
    }
    const label = el("label", { for: id, text: name });
    const wrap = el("div", { class: `field ${extraClass}` }, label, control, help, error);
    return {
      wrap,
      setError: (msg) => {
        error.textContent = msg || "";
        wrap.classList.toggle("invalid", Boolean(msg));
        if (control.setAttribute) control.setAttribute("aria-invalid", msg ? "true" : "false");
      },
    };
  }

  nextId(path) {
    return `f-${path.join("-") || "root"}-${uid++}`;
  }

  number(s, value, path, name, required, description) {
    const id = this.nextId(path);
    const v = value ?? s.default;
    const input = el("input", {
      id, type: "number", name: path.join("."), step: s.type === "integer" ? "1" : "any",
      min: s.minimum, max: s.maximum, value: v ?? "", "data-path": JSON.stringify(path),
    });
    const row = this.row(name, description, input, id);
    return this.register(path, {
      el: row.wrap,
      setError: row.setError,
      get: () => (input.value === "" ? undefined : Number(input.value)),
      check: () => {
        const msg = numberProblem(s, input.value, required);
        return msg ? [{ path, msg }] : [];
      },
      input,
    });
  }

  text(s, value, path, name, required, description) {
    const id = this.nextId(path);
    const input = el("input", { id, type: "text", name: path.join("."), value: value ?? s.default ?? "" });
    const row = this.row(name, description, input, id);
    return this.register(path, {
      el: row.wrap,
      setError: row.setError,
      get: () => (input.value === "" && !required ? undefined : input.value),
      check: () => {
        if (required && !input.value) return [{ path, msg: "required" }];
        if (s.maxLength && input.value.length > s.maxLength) return [{ path, msg: `at most ${s.maxLength} characters` }];
        return [];
      },
    });
  }

  checkbox(s, value, path, name, description) {
    const id = this.nextId(path);
    const input = el("input", { id, type: "checkbox", name: path.join(".") });
    input.checked = Boolean(value ?? s.default);
    const row = this.row(name, description, input, id, "check");
    return this.register(path, { el: row.wrap, setError: row.setError, get: () => input.checked, check: () => [] });
  }

  select(s, value, path, name, description) {
    const id = this.nextId(path);
    const input = el("select", { id, name: path.join(".") }, ...s.enum.map((o) => el("option", { value: JSON.stringify(o), text: String(o) })));
    const v = value ?? s.default ?? s.enum[0];
    input.value = JSON.stringify(v);
    const row = this.row(name, description, input, id);
    return this.register(path, { el: row.wrap, setError: row.setError, get: () => JSON.parse(input.value), check: () => [] });
  }

  tuple(s, items, value, path, name, required, description) {
    const id = this.nextId(path);
    const n = s.maxItems;
    const v = value ?? s.default ?? [];
    const inputs = Array.from({ length: n }, (_, i) =>
      el("input", { type: "number", step: "any", value: v[i] ?? "", "aria-label": `${name} [${i}]`, id: i ? undefined : id }),
    );
    const group = el("span", { class: "tuple" }, ...inputs);
    const row = this.row(name, description, group, id);
    return this.register(path, {
      el: row.wrap,
      setError: row.setError,
      get: () => (inputs.every((i) => i.value === "") ? undefined : inputs.map((i) => Number(i.value))),
      check: () => {
        if (inputs.every((i) => i.value === "")) return required ? [{ path, msg: "required" }] : [];
        const bad = inputs.findIndex((i) => numberProblem(items, i.value, true));
        return bad >= 0 ? [{ path, msg: `[${bad}]: ${numberProblem(items, inputs[bad].value, true)}` }] : [];
      },
    });
  }

  json(s, value, path, name, required, description) {
    const id = this.nextId(path);
    const v = value ?? s.default;
    const area = el("textarea", { id, rows: 3, spellcheck: "false", name: path.join(".") });
    area.value = v === undefined || v === null ? "" : JSON.stringify(v);
    const row = this.row(`${name} (JSON)`, description, area, id);
    return this.register(path, {
      el: row.wrap,
      setError: row.setError,
      get: () => (area.value.trim() === "" ? undefined : JSON.parse(area.value)),
      check: () => {
        if (area.value.trim() === "") return required ? [{ path, msg: "required" }] : [];
        try {
          const parsed = JSON.parse(area.value);
          if (s.type === "array" && !Array.isArray(parsed)) return [{ path, msg: "must be a JSON list" }];
          if (s.minItems && parsed.length < s.minItems) return [{ path, msg: `at least ${s.minItems} items` }];
          return [];
        } catch (err) {
          return [{ path, msg: `not valid JSON: ${err.message}` }];
        }
      },
    });
  }

  object(s, value, path, name, description) {
    const required = new Set(s.required || []);
    const v = value ?? {};
    const children = Object.entries(s.properties).map(([key, prop]) => [
      key,
      this.make(prop, v[key], [...path, key], key, required.has(key), prop.description),
    ]);
    const error = el("span", { class: "field-error", role: "alert" });
    const body = children.map(([, c]) => c.el).filter(Boolean);
    let node;
    if (path.length === 0) {
      node = el("div", { class: "fields" }, ...body, error);
    } else {
      node = el("fieldset", {}, el("legend", { text: name }), description ? el("small", { class: "help", text: description }) : null, ...body, error);
    }
    return this.register(path, {
      el: node,
      setError: (msg) => { error.textContent = msg || ""; },
      get: () => {
        const out = {};
        for (const [k, c] of children) {
          const cv = c.get();
          if (cv !== undefined) out[k] = cv;
        }
        return out;
      },
      check: () => children.flatMap(([, c]) => c.check()),
    });
  }

  optional(inner, value, path, name, description) {
    const toggle = el("input", { type: "checkbox", class: "use", "aria-label": `use ${name}`, title: `use ${name}` });
    toggle.checked = value !== undefined && value !== null;
    const child = this.make(inner, value, path, name, true, description);
    const sync = () => {
      for (const c of child.el.querySelectorAll("input, select, textarea, button")) c.disabled = !toggle.checked;
      child.el.classList.toggle("off", !toggle.checked);
    };
    toggle.addEventListener("change", sync);
    sync();
    const wrap = el("div", { class: "optional" }, toggle, child.el);
    return this.register(path, {
      el: wrap,
      setError: child.setError,
      get: () => (toggle.checked ? child.get() : undefined),
      check: () => (toggle.checked ? child.check() : []),
      toggle,
    });
  }

  union(s, options, value, path, name, description, nullable) {
    const id = this.nextId(path);
    const prop = s.discriminator?.propertyName || this.tag(this.deref(options[0]))?.[0] || "type";
    const tags = options.map((o) => this.tag(this.deref(o))?.[1] ?? this.deref(o).title);
    const picker = el("select", { id }, ...(nullable ? [el("option", { value: "", text: "(none)" })] : []), ...tags.map((t) => el("option", { value: t, text: t })));
    const slot = el("div", { class: "union-body" });
    const row = this.row(name, description, picker, id);
    let current = null;
    const show = (tag, v) => {
      slot.replaceChildren();
      const i = tags.indexOf(tag);
      current = i >= 0 ? this.make(options[i], v, path, `${name}: ${tag}`, true) : null;
      if (current) slot.append(current.el);
    };
    const start = value && value[prop] !== undefined ? value[prop] : nullable ? "" : tags[0];
    picker.value = start;
    show(start, value);
    picker.addEventListener("change", () => show(picker.value, { [prop]: picker.value }));
    const wrap = el("div", { class: "union" }, row.wrap, slot);
    const node = {
      el: wrap,
      setError: row.setError,
      get: () => (current ? current.get() : undefined),
      check: () => (current ? current.check() : []),
    };
    this.register(path, node);
    return node;
  }

  list(s, value, path, name, description) {
    const id = this.nextId(path);
    const itemsSchema = s.items;
    let items = [];
    const holder = el("div", { class: "list-items" });
    const error = el("span", { class: "field-error", role: "alert" });
    const add = el("button", { type: "button", id, class: "small", text: `Add to ${name}` });
    const render = (values) => {
      holder.replaceChildren();
      items = values.map((v, i) => {
        const child = this.make(itemsSchema, v, [...path, i], `${name} [${i}]`, true);
        const remove = el("button", { type: "button", class: "small", text: "Remove", "aria-label": `Remove ${name} [${i}]` });
        remove.addEventListener("click", () => render(items.filter((_, j) => j !== i).map((c) => c.get())));
        holder.append(el("div", { class: "list-item" }, child.el, remove));
        return child;
      });
    };
    add.addEventListener("click", () => render([...items.map((c) => c.get()), undefined]));
    render(Array.isArray(value) ? value : Array.isArray(s.default) ? s.default : []);
    const wrap = el("fieldset", { class: "list" }, el("legend", { text: name }), description ? el("small", { class: "help", text: description }) : null, holder, add, error);
    return this.register(path, {
      el: wrap,
      setError: (msg) => { error.textContent = msg || ""; },
      get: () => items.map((c) => c.get()),
      check: () => {
        const own = s.minItems && items.length < s.minItems ? [{ path, msg: `at least ${s.minItems} items` }] : [];
        return [...own, ...items.flatMap((c) => c.check())];
      },
    });
  }

  domain(path, name, description) {
    const id = this.nextId(path);
    const note = el("output", { id, class: "bound" });
    const refresh = () => {
      const g = this.ctx.domain();
      note.textContent = g ? `the drawn domain (${g.coordinates.length} ${g.type === "Polygon" ? "rings" : "polygons"})` : "draw a domain above first";
    };
    refresh();
    this.ctx.onDomainChange?.(refresh);
    const row = this.row(name, description, note, id);
    return this.register(path, {
      el: row.wrap,
      setError: (msg, rest) => {
        row.setError(msg);
        if (msg) this.ctx.onDomainError?.(rest || [], msg);
      },
      get: () => this.ctx.domain() ?? undefined,
      check: () => (this.ctx.domain() ? [] : [{ path, msg: "draw a domain, pick an example or paste GeoJSON" }]),
    });
  }

  mesh(value, path, name, description) {
    const id = this.nextId(path);
    const picker = el("select", { id }, el("option", { value: "uploaded", text: "the uploaded mesh" }), el("option", { value: "example", text: "the example's mesh" }));
    const uploaded = this.ctx.mesh();
    picker.value = uploaded || !value ? "uploaded" : "example";
    const row = this.row(name, description, picker, id);
    return this.register(path, {
      el: row.wrap,
      setError: row.setError,
      get: () => (picker.value === "uploaded" ? this.ctx.mesh() ?? undefined : value ?? undefined),
      check: () => {
        const v = picker.value === "uploaded" ? this.ctx.mesh() : value;
        return v ? [] : [{ path, msg: picker.value === "uploaded" ? "upload a mesh first" : "the example has no mesh here" }];
      },
    });
  }
}

function numberProblem(s, raw, required) {
  if (raw === "" || raw === undefined) return required ? "required" : "";
  const v = Number(raw);
  if (!Number.isFinite(v)) return "must be a finite number";
  if (s.type === "integer" && !Number.isInteger(v)) return "must be an integer";
  if (s.minimum !== undefined && v < s.minimum) return `must be at least ${s.minimum}`;
  if (s.maximum !== undefined && v > s.maximum) return `must be at most ${s.maximum}`;
  if (s.exclusiveMinimum !== undefined && v <= s.exclusiveMinimum) return `must be greater than ${s.exclusiveMinimum}`;
  if (s.exclusiveMaximum !== undefined && v >= s.exclusiveMaximum) return `must be less than ${s.exclusiveMaximum}`;
  return "";
}
