/* The page the phone script runs in: the session's link (its token), the API under it and
 * the participant's language. */

export var app = document.getElementById("app");
export var token = app.dataset.token;
export var api = "/api/phone/" + encodeURIComponent(token);

// The participant's language: the server sends this script's strings translated
// (message id -> text); a string without a translation shows in English.
var messages = JSON.parse(document.getElementById("messages").textContent || "{}");
export function t(message, params) {
  var text = Object.prototype.hasOwnProperty.call(messages, message) ? messages[message] : message;
  return text.replace(/\{(\w+)\}/g, function (whole, name) {
    return params && Object.prototype.hasOwnProperty.call(params, name) ? String(params[name]) : whole;
  });
}

// The page's language (the session's) asks the server for its refusals in it too.
export function postHeaders() {
  return { "Content-Type": "application/json", "Accept-Language": document.documentElement.lang || "en" };
}
