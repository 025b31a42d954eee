"""KML 2.2 (OGC), the document language of the KML export and of DJI's WPML files."""

KML_NS = "http://www.opengis.net/kml/2.2"
