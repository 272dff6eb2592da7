// Highlight the manual's code blocks with the highlight.js served beside this file (no CDN: the manual works offline).
hljs.highlightAll();
