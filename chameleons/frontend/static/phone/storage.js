/* Local storage: drafts and the outbox, kept per link (tolerates private mode). */

import { token } from "./context.js";

function key(name) { return "mc:" + token + ":" + name; }
export function load(name, fallback) {
  try {
    var text = localStorage.getItem(key(name));
    return text === null ? fallback : JSON.parse(text);
  } catch (e) { return fallback; }
}
export function store(name, value) {
  try { localStorage.setItem(key(name), JSON.stringify(value)); } catch (e) { /* full */ }
}
export function forget(name) {
  try { localStorage.removeItem(key(name)); } catch (e) { /* unavailable */ }
}
export function forgetAll() {
  try {
    Object.keys(localStorage).forEach(function (k) {
      if (k.indexOf("mc:" + token + ":") === 0) { localStorage.removeItem(k); }
    });
  } catch (e) { /* unavailable */ }
}
export function newClientId() {
  var bytes = new Uint8Array(16);
  crypto.getRandomValues(bytes); // works without https, unlike crypto.randomUUID
  return Array.prototype.map.call(bytes, function (b) {
    return ("0" + b.toString(16)).slice(-2);
  }).join("");
}
