// The part of three.js the fem2tmm report's 3-D view uses, exposed as the global THREE.
export { WebGLRenderer, Scene, PerspectiveCamera, OrthographicCamera, BufferGeometry, BufferAttribute,
  Float32BufferAttribute, Mesh, MeshLambertMaterial, MeshBasicMaterial, LineSegments, LineBasicMaterial,
  EdgesGeometry, AmbientLight, DirectionalLight, HemisphereLight, Color, Plane, Vector2, Vector3, Box3, Sphere,
  Raycaster, DoubleSide, Group, PlaneGeometry, SRGBColorSpace, LinearSRGBColorSpace, NoColorSpace, AxesHelper,
  PlaneHelper, Points, PointsMaterial } from 'three';
export { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
