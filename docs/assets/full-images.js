// Every figure in a page links to its full-size file, so a three-panel figure squeezed into the
// text column can be opened at full size (no image-zoom plugin is installed).
document$.subscribe(function () {
  document.querySelectorAll("article img").forEach(function (img) {
    if (img.closest("a")) {
      return;
    }
    var link = document.createElement("a");
    link.href = img.getAttribute("src");
    link.className = "full-image";
    link.title = "open the full-size image";
    img.replaceWith(link);
    link.appendChild(img);
  });
});
